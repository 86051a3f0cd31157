"""A robot description's parameters and points without a graph (no node process): the
description parameters checked before anything loads, and a description's points given in its
ground link's 3-D frame and projected back into its plane."""

from __future__ import annotations

import pytest
from builtin_interfaces.msg import Time
from node_description_helpers import CASES, fixture, mechanism_of, text_of

from linkage_ros.core.loading import load_scene


def test_description_parameters_are_checked_before_anything_loads(tmp_path):
    from linkage_ros.core.errors import SceneError
    from linkage_ros.params import ConfigError, load_engine, make_config

    six_bar = fixture('grbda_six_bar.urdf')
    config = make_config({'scene': six_bar, 'actuated': ['']})
    assert config.actuated == () and config.source == six_bar
    scene, engine = load_engine(config)
    assert (
        scene.mechanism.output_joint_names
        == mechanism_of(CASES['grbda_six_bar']).output_joint_names
    )
    text = make_config({'robot_description': text_of('grbda_four_bar.urdf')})
    assert text.source == 'the robot_description parameter'
    assert load_engine(text)[0].mechanism.name == 'four_bar'
    # the topic: the scene is not read (its default names a packaged scene anyway)
    assert make_config({'robot_description_topic': '/robot_description'}).source == (
        'robot_description_topic /robot_description'
    )
    bad = {
        'closures': ({'scene': six_bar, 'closures': str(tmp_path / 'none.yaml')}, 'no such file'),
        'actuated twice': ({'actuated': ['joint1', 'joint1']}, 'twice'),
        'actuated empty name': ({'actuated': ['joint1', '']}, 'joint names'),
        'both sources': (
            {'robot_description': '<robot/>', 'robot_description_topic': 'robot_description'},
            'set one of them',
        ),
        'topic name': ({'robot_description_topic': 'robot description'}, 'topic name'),
        'joint_states_in': ({'joint_states_in': '/joint_states/'}, 'topic name'),
        'publish_inputs alone': ({'publish_inputs': True}, 'set joint_states_in too'),
        'publish_inputs not a bool': (
            {'joint_states_in': 'hw', 'publish_inputs': 'yes'},
            'must be true or false',
        ),
    }
    for case, (params, fragment) in bad.items():
        with pytest.raises(ConfigError, match=fragment):
            make_config(params)
        assert case
    # a side file with a scene YAML: the loader refuses it, naming the file
    with pytest.raises(SceneError, match='closures applies to a robot description'):
        load_engine(
            make_config(
                {'scene': 'four_bar', 'closures': fixture('gepetto_5bar_linkage/robot.yaml')}
            )
        )


def test_points_in_and_out_of_a_description_are_3d_in_its_ground_frame():
    """~/points and the markers give a description's points in its ground link's 3-D frame;
    ~/target_point and path positions are projected back into its plane."""
    from geometry_msgs.msg import Point, PointStamped

    from linkage_ros.conversions import point_stamped_to_xy, result_to_points
    from linkage_ros.core.solver import Solver

    mech = load_scene(
        fixture('gepetto_5bar_linkage/robot.urdf'),
        closures=fixture('gepetto_5bar_linkage/robot.yaml'),
    ).mechanism
    r = Solver(mech).solve(mech.joint_coordinates.to_scene({'mot1': 0.2, 'mot2': -0.1}))
    msgs = result_to_points(r, ['free1'], Time(), 'built', mech=mech)
    p = msgs['free1'].point
    assert (p.x, p.y, p.z) == pytest.approx(mech.point_3d('free1', *r.points['free1']))
    assert p.x == pytest.approx(0.15)  # the pin's depth along x: the chain moves in yz
    back = point_stamped_to_xy(PointStamped(point=Point(x=p.x, y=p.y, z=p.z)), 'free1', mech)
    assert back == pytest.approx(r.points['free1'], abs=1e-15)
