"""Show a scene in RViz: linkage_node, robot_state_publisher and rviz2.

    ros2 launch linkage_ros view.launch.py scene:=excavator
    ros2 launch linkage_ros view.launch.py scene:=four_bar demo_sweep:=false prefix:=left_

robot_description is `linkage urdf --prefix=PREFIX --frame-id=FRAME_ID -- SCENE`, run as an
argument list (a scene path with a space stays one argument): its joint names are the node's
joint_states names, so robot_state_publisher puts every link and point frame
where the solver says. The node publishes the reference pose at start-up and republishes its
state at publish_rate; demo_sweep (default true here) drives the first actuator so the
mechanism moves without a command. Needs the launch, launch_ros, robot_state_publisher and
rviz2 packages (package.xml lists them).
"""

import subprocess

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackageShare

from linkage_ros.cli.urdf import urdf_argv


def robot_state_publisher(context):
    """robot_state_publisher with the URDF of `linkage urdf` (the package's CLI, setup.py
    console_scripts), run as an argument list: launch's Command substitution splits its
    text on spaces, and a scene path with a space failed."""
    scene, prefix, frame_id = (
        LaunchConfiguration(name).perform(context) for name in ('scene', 'prefix', 'frame_id')
    )
    argv = urdf_argv(scene, prefix, frame_id)
    done = subprocess.run(argv, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f'{argv} failed (exit {done.returncode}): {done.stderr.strip()}')
    return [
        Node(
            package='robot_state_publisher',
            executable='robot_state_publisher',
            parameters=[{'robot_description': ParameterValue(done.stdout, value_type=str)}],
            output='screen',
        )
    ]


def generate_launch_description() -> LaunchDescription:
    scene = LaunchConfiguration('scene')
    prefix = LaunchConfiguration('prefix')
    frame_id = LaunchConfiguration('frame_id')
    return LaunchDescription(
        [
            DeclareLaunchArgument('scene', default_value='four_bar', description='scene'),
            DeclareLaunchArgument('prefix', default_value='', description='joint/frame prefix'),
            DeclareLaunchArgument('frame_id', default_value='world', description='root frame'),
            DeclareLaunchArgument('demo_sweep', default_value='true', description='demo motion'),
            DeclareLaunchArgument('rviz', default_value='true', description='start rviz2'),
            Node(
                package='linkage_ros',
                executable='linkage_node',
                parameters=[
                    {
                        'scene': scene,
                        'prefix': prefix,
                        'frame_id': frame_id,
                        'demo_sweep': ParameterValue(
                            LaunchConfiguration('demo_sweep'), value_type=bool
                        ),
                    }
                ],
                output='screen',
            ),
            OpaqueFunction(function=robot_state_publisher),
            Node(
                package='rviz2',
                executable='rviz2',
                arguments=[
                    '-d',
                    PathJoinSubstitution([FindPackageShare('linkage_ros'), 'rviz', 'linkage.rviz']),
                ],
                condition=IfCondition(LaunchConfiguration('rviz')),
            ),
        ]
    )
