"""Two TCA muscles side by side, ``/finger1`` and ``/finger2``, with clamp frames and RViz.

    ros2 launch tca_ros two_muscles.launch.py               # rviz:=false: without RViz

Needs a ROS 2 Jazzy install (launch, launch_ros, tf2_ros, rviz2); PyPI has none of them.
Each muscle is one ``tca_node`` in its namespace with a shipped params file. The node
names its frames after its namespace (``finger1/tca_base``, see
``tca_ros.ros.node_params.namespaced_name``) but publishes no TF, so one
``static_transform_publisher`` per muscle places that clamp frame in ``world``, the
muscles side by side along x. RViz opens ``rviz/tca.rviz``: Fixed Frame ``world``, one
Marker display per muscle on ``/<namespace>/shape``, and TF.
"""
import os

#: (namespace, params file in share/tca_ros/config, x of the clamp in world (m)).
MUSCLES = (
    ('finger1', 'free_stroke.yaml', 0.0),
    ('finger2', 'self_coiled.yaml', 0.02),
)
WORLD_FRAME = 'world'
BASE_FRAME = 'tca_base'  # the node's default base_frame, before the namespace prefix
RVIZ_CONFIG = 'tca.rviz'  # in share/tca_ros/rviz


def clamp_frame(namespace):
    """Return the clamp frame ``tca_node`` uses in ``namespace`` by default."""
    return f'{namespace.strip("/")}/{BASE_FRAME}'


def static_transform_arguments(namespace, x):
    """Return static_transform_publisher arguments placing the clamp at x (m) in world."""
    return ['--x', f'{x:g}', '--y', '0', '--z', '0',
            '--frame-id', WORLD_FRAME, '--child-frame-id', clamp_frame(namespace)]


def generate_launch_description():
    """Return the launch description: per muscle a tca_node and its clamp frame; RViz."""
    # Imported here rather than at the top: the tables above stay importable (and are
    # checked against the node by the tests) where launch is not installed.
    from ament_index_python.packages import get_package_share_directory
    from launch import LaunchDescription
    from launch.actions import DeclareLaunchArgument
    from launch.conditions import IfCondition
    from launch.substitutions import LaunchConfiguration
    from launch_ros.actions import Node

    share = get_package_share_directory('tca_ros')
    actions = [DeclareLaunchArgument(
        'rviz', default_value='true', description='Start rviz2 with rviz/tca.rviz.')]
    for namespace, params_file, x in MUSCLES:
        actions.append(Node(
            package='tca_ros', executable='tca_node', name='tca', namespace=namespace,
            parameters=[os.path.join(share, 'config', params_file)], output='screen'))
        actions.append(Node(
            package='tf2_ros', executable='static_transform_publisher',
            name=f'{namespace}_clamp_tf', arguments=static_transform_arguments(namespace, x)))
    actions.append(Node(
        package='rviz2', executable='rviz2', name='rviz2',
        arguments=['-d', os.path.join(share, 'rviz', RVIZ_CONFIG)],
        condition=IfCondition(LaunchConfiguration('rviz'))))
    return LaunchDescription(actions)
