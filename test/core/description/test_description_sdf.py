"""Imported SDF descriptions checked by a small SDFormat pose evaluator written here, which shares
nothing with linkage_ros's core (Drake's reading: a joint brings its parent frame and the joint
frame on its child together at value 0): Drake's four-bar closes in it, with the link lengths
between the solved pins (driver 1, coupler 4.8, rocker 2, ground 4 m), and so does an assembled
SDF drawn in the xz plane.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from description_consumers_helpers import (
    CLOSE,
    DRAKE,
    DRAKE_SIDE,
    EXACT,
    SdfModel,
    angle_diff,
    described,
)

from linkage_ros.core.description import DescriptionError, import_description
from linkage_ros.core.solver import Solver

# ---- Drake's four-bar SDF: an independent SDFormat pose evaluator ----------------------------


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


def test_an_axis_in_the_model_frame_turns_about_the_models_direction(tmp_path):
    """Drake's four-bar with its driver's parent frame Wd turned over (rpy pi, 0, pi/6): the
    driver is joined to Wd as it stands and turns about the model's +z, as its axis says
    (expressed_in __model__). Oracle: the driver's coupler pin at Wd + Rz(q) R_Wd (0, 1, 0)
    (the pin is 1 m along the driver's y), and the loop closed in the SDF evaluator. It had
    turned about -z: the axis was read in the child's drawn joint frame, which the joining
    then turned over (an outside reviewer's find: the loop open by 1.5 m in an FK of its own)."""
    flipped = DRAKE.read_text().replace(
        '<pose relative_to="world">-2 0 0 0 0 0</pose>',
        '<pose relative_to="world">-2 0 0 3.141592653589793 0 0.5235987755982988</pose>',
    )
    assert flipped != DRAKE.read_text()
    path = tmp_path / 'drake_four_bar_wd_turned_over.sdf'
    path.write_text(flipped)
    mech = import_description(str(path), closures=str(DRAKE_SIDE)).mechanism
    model = SdfModel(flipped)
    solver = Solver(mech)
    rz = lambda a: np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])  # noqa: E731
    # R_Wd (0, 1, 0): the x turn takes y to -y, then the pi/6 yaw
    pin_at_zero = rz(math.pi / 6) @ np.array([0.0, -1.0])
    for q in (0.3, 1.0, -0.7):
        result = solver.solve(mech.joint_coordinates.to_scene({'world_driver': q}))
        assert result.success, result.reason
        want = np.array([-2.0, 0.0]) + rz(q) @ pin_at_zero
        assert math.dist(result.points['driver_coupler'], want) <= EXACT * 4.8, q
        assert model.loop_miss(described(mech, result)) <= CLOSE * 4.8, q


def test_a_quaternion_pose_reads_as_its_roll_pitch_yaw():
    """SDFormat 1.9's rotation_format="quat_xyzw": the coupler's pose of the xz four-bar
    written as a quaternion (from its roll-pitch-yaw by the textbook formula, scaled by 3:
    SDFormat's quaternion need not be of length 1) gives the same answers. It had been refused
    as 'expects 6 finite numbers' (an outside reviewer's find)."""
    r, p, y = 0.2, -0.3, 0.1
    cr, sr = math.cos(r / 2), math.sin(r / 2)
    cp, sp = math.cos(p / 2), math.sin(p / 2)
    cy, sy = math.cos(y / 2), math.sin(y / 2)
    quat = (
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    )
    rpy_pose = '<pose>0.3 0 0.4 0.2 -0.3 0.1</pose>'
    quat_pose = '<pose rotation_format="quat_xyzw">0.3 0 0.4 {}</pose>'.format(
        ' '.join(repr(3.0 * c) for c in quat)
    )
    assert SDF_XZ.count(rpy_pose) == 1
    as_quat = SDF_XZ.replace(rpy_pose, quat_pose)
    a = import_description(SDF_XZ, actuated=['crank_joint'], text=True).mechanism
    b = import_description(as_quat, actuated=['crank_joint'], text=True).mechanism
    for q in (-2.0, 0.3, 1.7):
        ra = Solver(a).solve(a.joint_coordinates.to_scene({'crank_joint': q}))
        rb = Solver(b).solve(b.joint_coordinates.to_scene({'crank_joint': q}))
        assert ra.success and rb.success
        assert described(a, ra) == pytest.approx(described(b, rb), abs=1e-12)
        for point, xy in ra.points.items():
            assert math.dist(xy, rb.points[point]) < 1e-12, point
    zero = as_quat.replace(
        '0.3 0 0.4 {}'.format(' '.join(repr(3.0 * c) for c in quat)), '0.3 0 0.4 0 0 0 0'
    )
    with pytest.raises(DescriptionError, match='quaternion of length 0'):
        import_description(zero, actuated=['crank_joint'], text=True)
