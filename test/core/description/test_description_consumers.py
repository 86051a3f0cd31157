"""Imported descriptions checked by consumers that share nothing with linkage_ros's core.

Every URDF fixture is imported, solved over sweeps of its actuated joints (in each assembly mode
where the plan has two or more), and the description's own joint values (``output_joints``) are
fed to Pinocchio, which builds its model from the same URDF text itself. Pinocchio's forward
kinematics must close every loop (the closure points stated below, read off the fixtures by
hand, not taken from the importer) to 1e-9 of the mechanism's size, with the actuated joints at
the commanded values to 1e-12. Where a command cannot be solved, Pinocchio says why: the loop
cannot reach (a distance it computes exceeds the free links' reach).

Drake's SDF four-bar is checked by a small SDFormat pose evaluator written here (Drake's
reading: a joint brings its parent frame and the joint frame on its child together at value 0)
and by the link lengths between the solved pins (driver 1, coupler 4.8, rocker 2, ground 4 m).
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from oracles import homogeneous, rpy_matrix

from linkage_ros.core.description import Imported, import_description
from linkage_ros.core.solver import Solver

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

# The closure of each URDF fixture, as (link, point in the link's frame) pairs that must meet.
FOUR_BAR_PIN = (('link2', (1.0, 0.0, 0.0)), ('link3', (0.5, 0.0, 0.0)))
SIX_BAR_PIN = (('link3', (0.3, 0.0, 0.0)), ('link5', (0.5, 0.0, 0.0)))
ROBOTIQ_PINS = (
    (
        ('robotiq_85_left_inner_knuckle_link', (0.0371575, 0.0, 0.04342168)),
        ('robotiq_85_left_finger_tip_link', (-0.01790114, 0.0, 0.00651548)),
    ),
    (
        ('robotiq_85_right_inner_knuckle_link', (-0.0371575, 0.0, 0.04342168)),
        ('robotiq_85_right_finger_tip_link', (0.01790114, 0.0, 0.00651548)),
    ),
)
ROBOTIQ_KNUCKLE = 'robotiq_85_left_knuckle_joint'
ROBOTIQ_RIGHT_KNUCKLE = 'robotiq_85_right_knuckle_joint'


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
    return dict(zip(mech.output_joint_names, map(float, mech.output_joints(result.joints))))


def pin_miss(robot: PinocchioRobot, values, pins) -> float:
    robot.place(values)
    return max(float(np.linalg.norm(robot.point(*a) - robot.point(*b))) for a, b in pins)


# ---- the grbda four-bar: a parallelogram drawn flat at its change point ----------------------


def parallelogram(q: float) -> dict[str, float]:
    """Crank 0.5 about the origin, coupler 1.0, rocker 0.5 about (1, 0): the coupler stays
    parallel to the ground, the rocker parallel to the crank."""
    return {'joint1': q, 'joint2': -q, 'joint3': q}


def anti_parallelogram(q: float) -> dict[str, float]:
    """The crossed mode: the coupler pin C is the parallelogram's reflected in the diagonal
    from the crank pin B to the rocker pivot D (the triangle BCD folded over BD keeps |BC| and
    |DC|). joint3 = the rocker's direction (its pin is on its +x axis); joint2 = the coupler's
    direction (its pin on its +x axis) minus the crank's."""
    b = 0.5 * np.array([math.cos(q), math.sin(q)])
    d = np.array([1.0, 0.0])
    c_par = b + np.array([1.0, 0.0])
    u = (d - b) / np.linalg.norm(d - b)
    rel = c_par - b
    c = b + 2.0 * (rel @ u) * u - rel
    rocker = math.atan2(c[1] - d[1], c[0] - d[0])
    coupler = math.atan2(c[1] - b[1], c[0] - b[0])
    return {'joint1': q, 'joint2': math.remainder(coupler - q, 2 * math.pi), 'joint3': rocker}


@pytest.fixture(scope='module')
def four_bar():
    return import_description(str(FOUR_BAR))


@pytest.mark.parametrize('branch', ['+', '-', 'continuous'])
def test_four_bar_closes_in_pinocchio_over_the_full_turn(four_bar, branch):
    mech = four_bar.mechanism
    robot = PinocchioRobot(FOUR_BAR)
    solver = Solver(mech, branch=branch)
    for q in np.linspace(-math.pi, math.pi, 181):
        values = described(mech, solver.solve(mech.joint_coordinates.to_scene({'joint1': q})))
        assert pin_miss(robot, values, [FOUR_BAR_PIN]) <= CLOSE * 1.0, (branch, q)
        assert angle_diff(values['joint1'], q) <= EXACT, (branch, q, values)


def test_four_bar_both_modes_through_the_change_point(four_bar):
    """The drawing is flat (q = 0), where the parallelogram and the anti-parallelogram meet;
    the other change point is q = pi. A branch sign is the side of the dyad (loop1 from circles
    about joint3 and joint2) its pin is on, and the parallelogram changes sides at each change
    point: for joint1 in (0, pi) branch '-' is the parallelogram and '+' the anti-parallelogram;
    for joint1 in (-pi, 0) the other way round. Each checked against the closed forms above."""
    mech = four_bar.mechanism
    solve = {b: Solver(mech, branch=b) for b in '+-'}
    # (nearer than ~1e-6 rad to a change point the two modes differ by less than the pin's
    # conditioning there: a length error e moves the pin by ~sqrt(e))
    for q in [*np.linspace(-3.1, -1e-6, 40), *np.linspace(1e-6, 3.1, 40)]:
        got = {
            b: described(mech, s.solve(mech.joint_coordinates.to_scene({'joint1': q})))
            for b, s in solve.items()
        }
        par, anti = parallelogram(q), anti_parallelogram(q)
        expect = {'-': par, '+': anti} if q > 0 else {'+': par, '-': anti}
        for b in '+-':
            for name, value in expect[b].items():
                assert angle_diff(got[b][name], value) <= 1e-9, (q, b, name, got[b], value)
    # at the change points themselves both modes are the flat drawing (or its half turn)
    for q, flat in [(0.0, parallelogram(0.0)), (math.pi, parallelogram(math.pi))]:
        for s in solve.values():
            values = described(mech, s.solve(mech.joint_coordinates.to_scene({'joint1': q})))
            for name, value in flat.items():
                assert angle_diff(values[name], value) <= 1e-6, (q, name, values)


def test_closed_forms_are_four_bars():
    """The oracle itself: both closed forms keep the four link lengths."""
    for q in np.linspace(-3, 3, 25):
        for mode in (parallelogram(q), anti_parallelogram(q)):
            b = 0.5 * np.array([math.cos(q), math.sin(q)])
            c = b + np.array(
                [math.cos(q + mode['joint2']), math.sin(q + mode['joint2'])]
            )  # coupler 1.0
            r = np.array([1.0, 0.0]) + 0.5 * np.array(
                [math.cos(mode['joint3']), math.sin(mode['joint3'])]
            )
            assert np.linalg.norm(c - r) < 1e-12


def four_bar_forms(tmp_path: Path) -> dict[str, Imported]:
    """The grbda four-bar's one closure stated each way a description can state it."""
    text = FOUR_BAR.read_text()
    loop = text[text.index('    <loop') : text.index('</robot>')]
    tree = text.replace(loop, '')
    constraint = (
        '<constraint name="loop1" type="revolute">'
        '<parent link="link2"/><parent_origin xyz="1 0 0" rpy="0 0 0"/>'
        '<parent_axis xyz="0 0 1"/>'
        '<child link="link3"/><child_origin xyz="0.5 0 0"/></constraint>\n'
    )
    closures = tmp_path / 'four_bar.closures.yaml'
    closures.write_text(
        'closures:\n'
        '  - {name: loop1, type: revolute, a: {link: link2, xyz: [1.0, 0, 0]},\n'
        '     b: {link: link3, xyz: [0.5, 0, 0]}, axis: [0, 0, 1]}\n'
        'actuated: [joint1]\n'
    )
    return {
        'loop': import_description(str(FOUR_BAR)),
        'sucessor': import_description(text.replace('successor', 'sucessor'), text=True),
        'constraint': import_description(
            tree.replace('</robot>', constraint + '</robot>'), text=True
        ),
        'closure file': import_description(
            tree.replace(' independent="true"', ''), closures=str(closures), text=True
        ),
    }


def test_four_bar_closure_forms_agree_in_pinocchio(tmp_path):
    """URDF+ <loop> (with generalized_rbda's 'sucessor' spelling too), the urdfdom <constraint>
    and a closure file: the same mechanism, the same joint values in each mode, and Pinocchio
    closes each."""
    forms = four_bar_forms(tmp_path)
    robot = PinocchioRobot(FOUR_BAR)
    for branch in '+-':
        solvers = {k: Solver(v.mechanism, branch=branch) for k, v in forms.items()}
        for q in np.linspace(-3.0, 3.0, 37):
            got = {}
            for form, solver in solvers.items():
                mech = forms[form].mechanism
                got[form] = described(
                    mech, solver.solve(mech.joint_coordinates.to_scene({'joint1': q}))
                )
                assert pin_miss(robot, got[form], [FOUR_BAR_PIN]) <= CLOSE, (form, q)
            for form, values in got.items():
                for name, value in values.items():
                    assert angle_diff(value, got['loop'][name]) <= 1e-9, (form, q, branch)


@pytest.mark.parametrize('flip', ['joint1', 'joint2', 'joint3', 'loop1'])
def test_four_bar_with_an_axis_reversed_closes_in_pinocchio(flip):
    """One axis written the other way round (a joint's value then turns clockwise; a loop's
    axis only states the plane): Pinocchio, reading the same edited text, still closes the
    loop at every value, and the commanded joint is where it was sent."""
    text = FOUR_BAR.read_text()
    head = f'<joint name="{flip}"' if flip != 'loop1' else '<loop name="loop1"'
    at = text.index(head)
    axis = text.index('<axis xyz="0 0 1"/>', at)
    text = text[:axis] + '<axis xyz="0 0 -1"/>' + text[axis + len('<axis xyz="0 0 1"/>') :]
    mech = import_description(text, text=True).mechanism
    robot = PinocchioRobot(text)
    for branch in '+-':
        solver = Solver(mech, branch=branch)
        for q in np.linspace(-3.0, 3.0, 31):
            values = described(mech, solver.solve(mech.joint_coordinates.to_scene({'joint1': q})))
            assert pin_miss(robot, values, [FOUR_BAR_PIN]) <= CLOSE, (flip, branch, q, values)
            assert angle_diff(values['joint1'], q) <= EXACT


# ---- the grbda six-bar: 3 DOF, 0.30 m open as drawn ------------------------------------------


@pytest.mark.parametrize('branch', ['+', '-', 'continuous'])
def test_six_bar_closes_in_pinocchio(branch):
    imported = import_description(str(SIX_BAR))
    assert imported.actuated == ('joint1', 'joint2', 'joint3')
    assert imported.gap == pytest.approx(0.30, abs=1e-9)
    mech = imported.mechanism
    robot = PinocchioRobot(SIX_BAR)
    solver = Solver(mech, branch=branch)
    grid = np.linspace(-2.9, 2.9, 7)
    solved = 0
    for q1 in grid:
        for q2 in grid:
            for q3 in grid:
                cmd = {'joint1': q1, 'joint2': q2, 'joint3': q3}
                # Pinocchio's own reach: link3's pin from joint4's pivot (the origin), which
                # the two-link arm link4 (0.4) + link5 (0.5) reaches between 0.1 and 0.9 m
                robot.place({**cmd, 'joint4': 0.0, 'joint5': 0.0})
                reach = float(np.linalg.norm(robot.point(*SIX_BAR_PIN[0])))
                result = solver.solve(mech.joint_coordinates.to_scene(cmd))
                if abs(reach - 0.9) < 1e-6 or abs(reach - 0.1) < 1e-6:
                    continue  # at the edge of the workspace: either answer is right
                assert result.success == (0.1 < reach < 0.9), (cmd, reach, result.reason)
                if not result.success:
                    continue
                solved += 1
                values = described(mech, result)
                assert pin_miss(robot, values, [SIX_BAR_PIN]) <= CLOSE * 0.9, (cmd, values)
                for name, q in cmd.items():
                    assert angle_diff(values[name], q) <= EXACT, (cmd, values)
    assert solved > 250


# ---- Gepetto's 5-bar: yz plane, a 6d closure of two dummy joint frames -----------------------


@pytest.mark.parametrize('branch', ['+', '-', 'continuous'])
def test_gepetto_five_bar_frames_coincide_in_pinocchio(branch):
    imported = import_description(str(GEPETTO), closures=str(GEPETTO_SIDE))
    assert imported.actuated == ('mot1', 'mot2')
    mech = imported.mechanism
    robot = PinocchioRobot(GEPETTO)
    solver = Solver(mech, branch=branch)
    size = 0.5
    solved = 0
    for m1 in np.linspace(-1.5, 1.5, 13):
        for m2 in np.linspace(-1.5, 1.5, 13):
            cmd = {'mot1': m1, 'mot2': m2}
            # Pinocchio's reach: the distal rods' pivots (free1, free2) are at most 0.46 + 0.46 m
            # apart in the plane for the loop to close
            robot.place({**cmd, 'free1': 0, 'free2': 0, 'closedloop1_A': 0, 'closedloop1_B': 0})
            p1 = robot.frame('rod_2').translation
            p2 = robot.frame('end_rod').translation
            span = float(np.linalg.norm((p1 - p2)[1:]))  # yz plane
            assert abs((p1 - p2)[0]) < 0.06  # the rods are stacked along x (the plane normal)
            result = solver.solve(mech.joint_coordinates.to_scene(cmd))
            if abs(span - 0.92) < 1e-6:
                continue
            assert result.success == (span < 0.92), (cmd, span, result.reason)
            if not result.success:
                continue
            solved += 1
            values = described(mech, result)
            robot.place(values)
            a, b = robot.frame('sphere'), robot.frame('sphere_2')
            assert np.linalg.norm(a.translation - b.translation) <= CLOSE * size, (cmd, values)
            assert np.linalg.norm(a.rotation - b.rotation) <= CLOSE, (cmd, values)
            for name, q in cmd.items():
                assert angle_diff(values[name], q) <= EXACT, (cmd, values)
    assert solved > 100


# ---- the Robotiq 2F-85: mimic-coupled fingers, cut pins stated in the side file --------------


def robotiq_mimics() -> dict[str, tuple[str, float, float]]:
    """The fixture's own <mimic> elements: joint -> (leader, multiplier, offset)."""
    out = {}
    for joint in ET.parse(ROBOTIQ).getroot().findall('joint'):
        m = joint.find('mimic')
        if m is not None:
            out[joint.get('name')] = (
                m.get('joint'),
                float(m.get('multiplier', '1')),
                float(m.get('offset', '0')),
            )
    return out


@pytest.mark.parametrize('branch', ['continuous', 'reference', '++', '+-', '-+', '--'])
def test_robotiq_closes_in_pinocchio(branch):
    imported = import_description(str(ROBOTIQ), closures=str(ROBOTIQ_SIDE))
    mech = imported.mechanism
    robot = PinocchioRobot(ROBOTIQ)
    solver = Solver(mech, branch=branch)
    mimics = robotiq_mimics()
    assert len(mimics) == 5
    for q in np.linspace(0.0, 0.8, 41):
        values = described(
            mech, solver.solve(mech.joint_coordinates.to_scene({ROBOTIQ_KNUCKLE: q}))
        )
        assert pin_miss(robot, values, ROBOTIQ_PINS) <= CLOSE * 0.06, (branch, q, values)
        assert angle_diff(values[ROBOTIQ_KNUCKLE], q) <= EXACT
        # the right knuckle is actuated through its mimic (multiplier -1)
        assert angle_diff(values[ROBOTIQ_RIGHT_KNUCKLE], -q) <= EXACT
        if branch in ('continuous', 'reference', '+-'):
            # the assembly mode the description is drawn in is the parallelogram its mimics
            # assume: every mimic holds (inner knuckle = knuckle, tip = -knuckle)
            for name, (leader, mult, off) in mimics.items():
                assert angle_diff(values[name], mult * values[leader] + off) <= 1e-9, (
                    branch,
                    q,
                    name,
                    values,
                )


# ---- Drake's four-bar SDF: an independent SDFormat pose evaluator ----------------------------


def _axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
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
                    axis = (self.initial(name)[:3, :3].T @ self.initial(frame)[:3, :3]) @ axis
                    axis /= np.linalg.norm(axis)
                    motion = homogeneous(_axis_rotation(axis, values[name]), [0, 0, 0])
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


def test_sdf_evaluator_sees_the_drawing_open():
    """The evaluator's reading of the unassembled drawing: open by |(2.8, 1) - (2, 2)| at 0,
    which is the gap the importer reports closing."""
    model = SdfModel(DRAKE)
    zero = {'world_driver': 0.0, 'world_rocker': 0.0, 'driver_coupler': 0.0}
    assert model.loop_miss(zero) == pytest.approx(math.hypot(0.8, 1.0), abs=1e-12)
    imported = import_description(str(DRAKE), closures=str(DRAKE_SIDE))
    assert imported.gap == pytest.approx(math.hypot(0.8, 1.0), abs=1e-9)


@pytest.mark.parametrize('branch', ['+', '-', 'continuous'])
def test_drake_four_bar_closes_in_an_independent_sdf_evaluator(branch):
    imported = import_description(str(DRAKE), closures=str(DRAKE_SIDE))
    assert imported.actuated == ('world_driver',)
    mech = imported.mechanism
    model = SdfModel(DRAKE)
    solver = Solver(mech, branch=branch)
    lengths = {
        ('world_driver', 'driver_coupler'): 1.0,
        ('driver_coupler', 'coupler_rocker'): 4.8,
        ('coupler_rocker', 'world_rocker'): 2.0,
        ('world_rocker', 'world_driver'): 4.0,
    }
    for q in np.linspace(-math.pi, math.pi, 121):  # a crank: the driver turns all the way
        result = solver.solve(mech.joint_coordinates.to_scene({'world_driver': q}))
        values = described(mech, result)
        assert set(values) == {'world_driver', 'world_rocker', 'driver_coupler'}
        assert model.loop_miss(values) <= CLOSE * 4.8, (branch, q, values)
        assert [j.get('name') for j in model.poses(values)[1]] == ['coupler_rocker']
        assert angle_diff(values['world_driver'], q) <= EXACT
        for (a, b), length in lengths.items():
            assert math.dist(result.points[a], result.points[b]) == pytest.approx(
                length, abs=CLOSE * 4.8
            )


#: A four-bar written the SDFormat way (not Drake's): drawn assembled, moving in the xz plane
#: (axes along y, stated in the model frame), links placed and turned by their poses, joint
#: frames on the children (the loop joint's placed by a pose relative to the model), the
#: parents named as links. Crank A (0, 0, 0) - B (0.3, 0, 0.4); coupler B - C (0.9, 0, 0.8);
#: rocker D (1, 0, 0) - C.
SDF_XZ = """<?xml version="1.0"?>
<sdf version="1.9">
  <model name="xz_four_bar">
    <link name="crank"><pose>0 0 0 0 0.9272952180016122 0</pose></link>
    <link name="coupler"><pose>0.3 0 0.4 0.2 -0.3 0.1</pose></link>
    <link name="rocker"><pose>1 0 0 0.3 0 0</pose></link>
    <joint name="crank_joint" type="revolute">
      <parent>world</parent><child>crank</child>
      <axis><xyz expressed_in="__model__">0 1 0</xyz></axis>
    </joint>
    <joint name="crank_coupler" type="revolute">
      <parent>crank</parent><child>coupler</child>
      <axis><xyz expressed_in="__model__">0 -1 0</xyz></axis>
    </joint>
    <joint name="rocker_joint" type="revolute">
      <parent>world</parent><child>rocker</child>
      <axis><xyz expressed_in="__model__">0 1 0</xyz></axis>
    </joint>
    <joint name="coupler_rocker" type="revolute">
      <pose relative_to="__model__">0.9 0 0.8 0 0 0</pose>
      <parent>coupler</parent><child>rocker</child>
      <axis><xyz expressed_in="__model__">0 1 0</xyz></axis>
    </joint>
  </model>
</sdf>
"""


def test_an_assembled_sdf_in_the_xz_plane_closes_in_the_sdf_evaluator():
    imported = import_description(SDF_XZ, actuated=['crank_joint'], text=True)
    assert imported.gap < 1e-12  # drawn assembled
    mech = imported.mechanism
    model = SdfModel(SDF_XZ)
    zero = {'crank_joint': 0.0, 'crank_coupler': 0.0, 'rocker_joint': 0.0}
    assert model.loop_miss(zero) < 1e-12  # the evaluator agrees that it is drawn closed
    for name, value in imported.values.items():
        assert angle_diff(value, 0.0) < 1e-9, (name, imported.values)
    # crank 0.5, coupler 0.721, rocker 0.806, ground 1: a Grashof crank-rocker? the crank is
    # shortest (0.5 + 1 <= 0.721 + 0.806): it turns all the way
    lengths = [0.5, math.hypot(0.6, 0.4), math.hypot(0.1, 0.8), 1.0]
    assert min(lengths) + max(lengths) <= sum(lengths) - min(lengths) - max(lengths)
    for branch in '+-':
        solver = Solver(mech, branch=branch)
        for q in np.linspace(-math.pi, math.pi, 61):
            result = solver.solve(mech.joint_coordinates.to_scene({'crank_joint': q}))
            values = described(mech, result)
            assert model.loop_miss(values) <= CLOSE, (branch, q, values)
            assert angle_diff(values['crank_joint'], q) <= EXACT


#: A slider-crank driven by its slide, written the usual way: the block on a prismatic joint,
#: the loop cut at the rod-block pin, which is the block's own frame (its slide point).
SLIDER_CRANK = """<robot name="slider_crank">
  <link name="base_link"/><link name="crank"/><link name="rod"/><link name="block"/>
  <joint name="joint1" type="revolute" independent="false">
    <parent link="base_link"/><child link="crank"/><axis xyz="0 0 1"/>
    <limit lower="-10" upper="10" effort="1" velocity="1"/>
  </joint>
  <joint name="joint2" type="revolute" independent="false">
    <parent link="crank"/><child link="rod"/><origin xyz="0.5 0 0" rpy="0 0 0.4"/>
    <axis xyz="0 0 1"/><limit lower="-10" upper="10" effort="1" velocity="1"/>
  </joint>
  <joint name="slide" type="prismatic" independent="true">
    <parent link="base_link"/><child link="block"/><origin xyz="1.2 0.1 0"/><axis xyz="1 0 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <loop name="pin" type="revolute">
    <predecessor link="rod"><origin xyz="1.0 0 0"/></predecessor>
    <successor link="block"/>
    <axis xyz="0 0 1"/>
  </loop>
</robot>
"""


def test_a_slider_crank_pinned_at_its_slide_frame_closes_in_pinocchio():
    """The block's pin is its slide frame: one place for the slider's point and the pin (this
    was refused as a link whose two points coincide). Driven by the slide over its reach, in
    both modes: Pinocchio puts the rod's end on the block, the crank turning as circle and
    line say (the crank pin 0.5 m from the origin, 1 m from the block pin)."""
    imported = import_description(SLIDER_CRANK, text=True)
    assert imported.actuated == ('slide',)
    mech = imported.mechanism
    robot = PinocchioRobot(SLIDER_CRANK)
    pin_pair = (('rod', (1.0, 0.0, 0.0)), ('block', (0.0, 0.0, 0.0)))
    for branch in '+-':
        solver = Solver(mech, branch=branch)
        for v in np.linspace(-0.65, 0.25, 19):  # the block at x = 0.55 .. 1.45, y = 0.1
            values = described(mech, solver.solve(mech.joint_coordinates.to_scene({'slide': v})))
            assert abs(values['slide'] - v) <= EXACT
            assert pin_miss(robot, values, [pin_pair]) <= CLOSE, (branch, v, values)
            block = robot.point('block', (0, 0, 0))
            crank_pin = robot.point('rod', (0, 0, 0))
            assert np.allclose(block, [1.2 + v, 0.1, 0.0], atol=1e-12)
            assert np.linalg.norm(crank_pin) == pytest.approx(0.5, abs=1e-12)
            assert np.linalg.norm(block - crank_pin) == pytest.approx(1.0, abs=1e-9)


# ---- the assembled reference pose ---------------------------------------------------------------


def test_assembled_at_given_values_closes_and_is_the_reference():
    """Assembled at stated actuated values (not 0): the pose the importer closed is a closed
    pose for Pinocchio and the SDF evaluator, and the scene solved at its reference (and at
    those values) gives it back."""
    cases = [
        (SIX_BAR, None, {'joint1': 0.3, 'joint2': -0.2, 'joint3': 0.5}),
        (DRAKE, DRAKE_SIDE, {'world_driver': 2.0}),
    ]
    for path, closures, values in cases:
        imported = import_description(
            str(path), closures=str(closures) if closures else None, values=values
        )
        assert {k: imported.values[k] for k in values} == values
        if path == SIX_BAR:
            robot = PinocchioRobot(SIX_BAR)
            assert pin_miss(robot, imported.values, [SIX_BAR_PIN]) <= CLOSE
        else:
            assert SdfModel(DRAKE).loop_miss(imported.values) <= CLOSE * 4.8
        mech = imported.mechanism
        solver = Solver(mech)
        for cmd in (solver.reference_values(), mech.joint_coordinates.to_scene(values)):
            got = described(mech, solver.solve(cmd))
            assert set(got) == set(imported.values)
            for name, value in imported.values.items():
                assert angle_diff(got[name], value) <= 1e-9, (path.name, name, got)


# ---- link angles: each link frame's x in the plane, as tf shows the frame ------------------


def _revolute_axis(path: Path, joint: str) -> np.ndarray:
    """A revolute joint's axis in its own frame, read off the URDF text (default +x)."""
    for el in ET.fromstring(path.read_text()).iter('joint'):
        if el.get('name') == joint:
            axis = el.find('axis')
            xyz = '1 0 0' if axis is None else axis.get('xyz', '1 0 0')
            return np.array([float(v) for v in xyz.split()])
    raise KeyError(joint)


LINK_ANGLE_CASES = {
    'grbda_four_bar': (FOUR_BAR, None, 'joint1', [{'joint1': 0.5}, {'joint1': -2.0}]),
    'grbda_six_bar': (
        SIX_BAR,
        None,
        'joint1',
        [
            {'joint1': 0.2, 'joint2': 0.3, 'joint3': -0.2},
            {'joint1': -0.4, 'joint2': 0.1, 'joint3': 0.3},
        ],
    ),
    'gepetto': (
        GEPETTO,
        GEPETTO_SIDE,
        'mot1',
        [{'mot1': 0.3, 'mot2': -0.2}, {'mot1': -0.5, 'mot2': 0.4}],
    ),
    'robotiq': (
        ROBOTIQ,
        ROBOTIQ_SIDE,
        ROBOTIQ_KNUCKLE,
        [{ROBOTIQ_KNUCKLE: 0.2}, {ROBOTIQ_KNUCKLE: 0.7}],
    ),
}


@pytest.mark.parametrize('name', list(LINK_ANGLE_CASES))
def test_a_links_angle_is_its_frames_x_in_the_plane(name):
    """ROBOT_DESCRIPTIONS.md: each link's axis lies along its frame's x, so a link's angle
    (answers, link targets, range --links) is the angle tf shows its frame at. Pinocchio places
    the frames at the answer's joint values; the plane's axes e1, e2 are the first two of the
    ground frame's x, y, z not along a revolute axis. Gepetto's rods have joint origins turned
    by pi and pi/2 about the normal: their angles were their rotation from the zero pose, off
    the frames by that much."""
    path, side, revolute, commands = LINK_ANGLE_CASES[name]
    mech = import_description(str(path), closures=str(side) if side else None).mechanism
    robot = PinocchioRobot(path)
    solver = Solver(mech)
    for cmd in commands:
        result = solver.solve(mech.joint_coordinates.to_scene(cmd))
        robot.place(described(mech, result))
        ground = robot.frame(mech.ground).rotation
        jid = robot.model.getJointId(revolute)
        n = robot.data.oMi[jid].rotation @ _revolute_axis(path, revolute)
        e1, e2 = [ground[:, k] for k in range(3) if abs(ground[:, k] @ n) < 0.5][:2]
        checked = 0
        for link, angle in result.links.items():
            if link == mech.ground:
                continue
            x = robot.frame(link).rotation[:, 0]
            assert angle_diff(angle, math.atan2(x @ e2, x @ e1)) <= 1e-9, (cmd, link, angle)
            checked += 1
        assert checked >= 3


TILTED_PIN = """<robot name="g3">
<link name="l0"/><link name="l1"/><link name="l2"/><link name="l3"/>
<link name="dA"/><link name="dB"/>
<joint name="j1" type="continuous"><parent link="l0"/><child link="l1"/><axis xyz="0 0 1"/></joint>
<joint name="j2" type="continuous"><parent link="l1"/><child link="l2"/><origin xyz="0.3 0 0"/>
<axis xyz="0 0 1"/></joint>
<joint name="j3" type="continuous"><parent link="l0"/><child link="l3"/><origin xyz="0.8 0 0"/>
<axis xyz="0 0 1"/></joint>
<joint name="cA" type="continuous"><parent link="l2"/><child link="dA"/><origin xyz="0.6 0.4 0"/>
<axis xyz="0 0 1"/></joint>
<joint name="cB" type="continuous"><parent link="l3"/><child link="dB"/>
<origin xyz="0.1 0.4 0" rpy="0.5 0 0"/><axis xyz="0 0 1"/></joint>
</robot>"""


@pytest.mark.parametrize('crank', [0.2, 1.0, -0.7])
def test_a_gepetto_pin_between_tilted_joint_frames_meets_in_pinocchio(tmp_path, crank):
    """A Gepetto '3d' closure (a pin: only the origins meet) between dummy joints whose frames
    tilt apart (cB rolled 0.5 rad): it was refused as 'its two frames are not turned about the
    plane normal only', which only a '6d' closure needs. The dummy joints are held at 0; the
    pin's two origins meet in Pinocchio's kinematics of the description itself."""
    path = tmp_path / 'g3.urdf'
    path.write_text(TILTED_PIN)
    side = tmp_path / 'g3.yaml'
    side.write_text("closed_loop: [['cA', 'cB']]\ntype: ['3d']\nname_mot: ['j1']\n")
    mech = import_description(str(path), closures=str(side)).mechanism
    result = Solver(mech).solve(mech.joint_coordinates.to_scene({'j1': crank}))
    assert result.success, result.reason
    values = described(mech, result)
    assert values['cA'] == values['cB'] == 0.0
    robot = PinocchioRobot(path)
    robot.place(values)
    a, b = robot.frame('dA').translation, robot.frame('dB').translation
    assert np.linalg.norm(a - b) <= CLOSE, (crank, values, a, b)
    assert angle_diff(values['j1'], crank) <= EXACT
