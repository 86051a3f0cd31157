"""A robot description's passive joints keep their <limit>s: an answer that would put one
beyond is refused (the chain closes there, but the robot cannot take the pose: a slider's
travel, a knuckle's stop), and a drawing assembled beyond one is warned about. An outside
integrator found them read (a passive revolute was wrapped into its limits) and never checked:
`--target slide_joint=-0.045` against a <limit lower="-0.03"> answered OK.

Oracle: the slider-crank by hand. In the base frame the crank (0.1 m, about -z, its <origin>
turned 0.3 rad) puts the rod's pin at A = 0.1 (cos(0.3 - q), sin(0.3 - q)); the slider's pin
is at (0.35 - s, 0.02) (prismatic along -x from (0.35, 0.02)) and the rod is 0.3 m long, so
s = 0.35 - A.x - sqrt(0.09 - (0.02 - A.y)^2) on the drawn branch."""

from __future__ import annotations

import math

import pytest

from linkage_ros.core.loading import load_scene
from linkage_ros.core.reference_warnings import reference_pose_warnings
from linkage_ros.core.solver import Solver
from linkage_ros.engine import Engine, EngineSettings

SLIDER = """<?xml version="1.0"?>
<robot name="slider_limited">
  <link name="world"/><link name="base_link"/><link name="crank"/><link name="rod"/>
  <link name="slider"/>
  <joint name="ground" type="fixed">
    <parent link="world"/><child link="base_link"/>
    <origin xyz="0.3 -0.2 0.1" rpy="0 0 0.5"/>
  </joint>
  <joint name="crank_joint" type="revolute">
    <parent link="base_link"/><child link="crank"/>
    <origin xyz="0 0 0" rpy="0 0 0.3"/><axis xyz="0 0 -1"/>
    <limit lower="-0.5" upper="2.0" effort="1" velocity="1"/>
  </joint>
  <joint name="rod_joint" type="revolute">
    <parent link="crank"/><child link="rod"/>
    <origin xyz="0.1 0 0.02"/><axis xyz="0 0 -1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/>
  </joint>
  <joint name="slide_joint" type="prismatic">
    <parent link="base_link"/><child link="slider"/>
    <origin xyz="0.35 0.02 0"/><axis xyz="-1 0 0"/>
    <limit lower="-0.03" upper="0.5" effort="1" velocity="1"/>
  </joint>
  <loop name="wrist_pin" type="revolute">
    <predecessor link="rod"><origin xyz="0.3 0 0"/></predecessor>
    <successor link="slider"><origin xyz="0 0 0"/></successor>
    <axis xyz="0 0 -1"/>
  </loop>
</robot>
"""


def slide(q: float) -> float:
    ax, ay = 0.1 * math.cos(0.3 - q), 0.1 * math.sin(0.3 - q)
    return 0.35 - ax - math.sqrt(0.09 - (0.02 - ay) ** 2)


@pytest.fixture
def mech(tmp_path):
    path = tmp_path / 'slider_limited.urdf'
    path.write_text(SLIDER)
    return load_scene(str(path), actuated=['crank_joint']).mechanism


def _slide_of(mech, result) -> float:
    return dict(zip(mech.output_joint_names, mech.output_joints(result.joints)))['slide_joint']


def test_a_command_within_the_passive_limit_is_answered(mech):
    engine = Engine(mech, EngineSettings())
    r = engine.command({'crank_joint': 1.0})
    assert r.success, r.reason
    assert _slide_of(mech, r) == pytest.approx(slide(1.0), abs=1e-12)
    assert -0.03 < slide(1.0) < 0.5


def test_a_command_beyond_it_is_refused_and_changes_nothing(mech):
    engine = Engine(mech, EngineSettings())
    good = engine.command({'crank_joint': 1.0})
    r = engine.command({'crank_joint': 0.0})
    assert not r.success
    assert f'passive joint slide_joint at {slide(0.0):.9g} m' in r.reason, r.reason
    assert 'beyond its <limit> [-0.03, 0.5] m' in r.reason
    assert engine.last.joints == good.joints


def test_a_target_beyond_it_is_refused(mech):
    engine = Engine(mech, EngineSettings())
    engine.command({'crank_joint': 1.0})
    r = engine.target({'slide_joint': -0.045})
    assert not r.success and 'passive joint slide_joint at -0.045 m' in r.reason, r.reason
    ok = engine.target({'slide_joint': -0.02})
    assert ok.success, ok.reason


def test_a_drawing_beyond_it_is_warned_about(mech):
    (warning,) = [w for w in reference_pose_warnings(Solver(mech)) if 'passive' in w]
    assert 'slide_joint' in warning and 'assemble_at' in warning


def rod_joint(q: float) -> float:
    """The rod's joint value by hand: the rod's angle from the crank's, about -z (both axes
    -z), wrapped into (-pi, pi]."""
    ax, ay = 0.1 * math.cos(0.3 - q), 0.1 * math.sin(0.3 - q)
    rod = math.atan2(0.02 - ay, (0.35 - slide(q)) - ax)
    return -math.remainder(rod - (0.3 - q), 2 * math.pi)


def test_passive_limits_a_turn_wide_limit_nothing_and_are_noted(tmp_path):
    """A passive revolute's <limit> written in degrees (lower="-150" upper="-90": 60 rad
    apart) refused every command: the answer's joint value was moved one turn toward the
    limits and reported 'beyond its <limit> [-150, -90] rad' (an outside integrator's gripper).
    Limits a turn or more apart limit nothing, as an actuated joint's: answered, the joint
    value where the mechanism puts it, and the import says so. Oracle: rod_joint by hand."""
    from linkage_ros.core.description import import_description

    text = SLIDER.replace(
        '<limit lower="-3" upper="3" effort="1" velocity="1"/>',
        '<limit lower="-150" upper="-90" effort="1" velocity="1"/>',
    )
    assert text != SLIDER
    path = tmp_path / 'degrees.urdf'
    path.write_text(text)
    mech = load_scene(str(path), actuated=['crank_joint']).mechanism
    engine = Engine(mech, EngineSettings())
    for q in (0.8, 1.0, 1.5):  # (the slide within its limits: slide(q) > -0.03)
        assert -0.03 < slide(q) < 0.5
        r = engine.command({'crank_joint': q})
        assert r.success, r.reason
        got = dict(zip(mech.output_joint_names, mech.output_joints(r.joints)))
        assert got['rod_joint'] == pytest.approx(rod_joint(q), abs=1e-12)
        assert not -150 <= rod_joint(q) <= -90  # (the old refusal's case)
    notes = import_description(str(path), actuated=['crank_joint']).notes
    assert any('limits of rod_joint (-150 .. -90 rad) span a full turn' in n for n in notes)
