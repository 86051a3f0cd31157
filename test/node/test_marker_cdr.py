"""~/markers written from a template (marker_cdr) against rclpy's serialiser and reader: the
bytes read back as the MarkerArray conversions.result_to_markers builds for the same
configuration and stamp (as rclpy sends it), for every packaged scene and a robot description
drawn in its 3-D frame."""

from __future__ import annotations

import pytest

rclpy = pytest.importorskip('rclpy')

from builtin_interfaces.msg import Time  # noqa: E402
from rclpy.serialization import deserialize_message, serialize_message  # noqa: E402
from visualization_msgs.msg import MarkerArray  # noqa: E402

from linkage_ros.conversions import result_to_markers  # noqa: E402
from linkage_ros.core.loading import load_scene  # noqa: E402
from linkage_ros.core.model import Scene  # noqa: E402
from linkage_ros.engine import Engine, EngineSettings  # noqa: E402
from linkage_ros.marker_cdr import MarkerBytes  # noqa: E402
from linkage_ros.resources import config_dir, scene_path  # noqa: E402

FIXTURES = config_dir().parent / 'test' / 'fixtures' / 'robot_descriptions'
SCENES = sorted(p.stem for p in config_dir().glob('*.yaml'))


def moved_states(engine: Engine, commands):
    """The reference pose, then the answers to ``commands`` (each a success)."""
    yield engine.last
    for command in commands:
        result = engine.command(command)
        assert result.success, result.reason
        yield result


def same_as_conversions(mech, engine: Engine, frame: str, commands) -> None:
    writer = MarkerBytes(mech, frame)
    for k, result in enumerate(moved_states(engine, commands)):
        sec, nanosec = 1_700_000_000 + k, 999_999_999 - k
        got = deserialize_message(writer.write(result, sec, nanosec), MarkerArray)
        want = result_to_markers(result, mech, Time(sec=sec, nanosec=nanosec), frame)
        # read back as sent: the colours are float32 on the wire
        assert got == deserialize_message(serialize_message(want), MarkerArray)
        # the drawing moves with the mechanism (not the template's placeholders)
        coordinates = [c for m in got.markers for p in m.points for c in (p.x, p.y, p.z)]
        assert all(c == 0.0 or abs(c) > 1e-200 for c in coordinates)


@pytest.mark.parametrize('scene', SCENES)
def test_markers_are_those_conversions_build(scene):
    mech = Scene.from_yaml(scene_path(scene)).mechanism
    engine = Engine(mech, EngineSettings())
    start = dict(engine.last.inputs)
    commands = [{a: v + 0.01 * k for a, v in start.items()} for k in (1, 2, 3)]
    same_as_conversions(mech, engine, 'world', commands)


def test_a_descriptions_markers_are_those_conversions_build_in_its_frame():
    """The serialiser against the message converter on a description's 3-D drawing (where each
    point is placed: point_3d, checked against Pinocchio in test_description_values)."""
    scene = load_scene(
        str(FIXTURES / 'picknik_robotiq_2f_85.expanded.urdf'),
        None,
        str(FIXTURES / 'picknik_robotiq_2f_85.closures.yaml'),
        None,
    )
    mech = scene.mechanism
    assert mech.joint_coordinates is not None  # drawn through point_3d's plane
    commands = [{'robotiq_85_left_knuckle_joint': q} for q in (0.2, 0.4)]
    same_as_conversions(mech, Engine(mech, EngineSettings()), 'base_link', commands)
