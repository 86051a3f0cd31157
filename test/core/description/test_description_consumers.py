"""Imported URDF fixtures checked by Pinocchio, which shares nothing with linkage_ros's core.

Every URDF fixture (the grbda four-bar and six-bar, Gepetto's 5-bar, the Robotiq 2F-85) is
imported, solved over sweeps of its actuated joints (in each assembly mode where the plan has two
or more), and the description's own joint values (``output_joints``) are fed to Pinocchio, which
builds its model from the same URDF text itself. Pinocchio's forward kinematics must close every
loop (the closure points read off the fixtures by hand, not taken from the importer) to 1e-9 of
the mechanism's size, with the actuated joints at the commanded values to 1e-12. Where a command
cannot be solved, Pinocchio says why: the loop cannot reach (a distance it computes exceeds the
free links' reach).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from description_consumers_helpers import (
    CLOSE,
    EXACT,
    FOUR_BAR,
    GEPETTO,
    GEPETTO_SIDE,
    ROBOTIQ,
    ROBOTIQ_KNUCKLE,
    ROBOTIQ_SIDE,
    SIX_BAR,
    SIX_BAR_PIN,
    PinocchioRobot,
    angle_diff,
    described,
    pin_miss,
)

from linkage_ros.core.description import Imported, import_description
from linkage_ros.core.solver import Solver

# The closure of each URDF fixture, as (link, point in the link's frame) pairs that must meet.
FOUR_BAR_PIN = (('link2', (1.0, 0.0, 0.0)), ('link3', (0.5, 0.0, 0.0)))


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


ROBOTIQ_RIGHT_KNUCKLE = 'robotiq_85_right_knuckle_joint'


# ---- Pinocchio -------------------------------------------------------------------------------


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
