"""Show a scene in RViz: linkage_node, robot_state_publisher and rviz2.

    ros2 launch linkage_ros view.launch.py scene:=excavator
    ros2 launch linkage_ros view.launch.py scene:=four_bar demo_sweep:=false prefix:=left_

robot_description is `linkage urdf SCENE --prefix PREFIX --frame-id FRAME_ID`: its joint names
are the node's joint_states names, so robot_state_publisher puts every link and point frame
where the solver says. The node publishes the reference pose at start-up and republishes its
state at publish_rate; demo_sweep (default true here) drives the first actuator so the
mechanism moves without a command. Needs the launch, launch_ros, robot_state_publisher and
rviz2 packages (package.xml lists them).
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitutions import Command, LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackageShare


def generate_launch_description() -> LaunchDescription:
    scene = LaunchConfiguration('scene')
    prefix = LaunchConfiguration('prefix')
    frame_id = LaunchConfiguration('frame_id')
    # `linkage urdf` is the package's CLI (setup.py console_scripts)
    description = ParameterValue(
        Command(['linkage urdf ', scene, " --prefix '", prefix, "' --frame-id ", frame_id]),
        value_type=str,
    )
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
            Node(
                package='robot_state_publisher',
                executable='robot_state_publisher',
                parameters=[{'robot_description': description}],
                output='screen',
            ),
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
