"""Launch the tracker on a robot's camera.

ros2 launch human_tracker human_tracker.launch.py image:=/camera/color/image_raw
    [camera_info:=/camera/color/camera_info] [namespace:=head_tracker] [target:=head|hand]
    [params_file:=/path/to/human_tracker.yaml] [single_process:=true]

With ``target:=hand`` the skin stage runs too (in process, or as ``skin_node``).
"""

from __future__ import annotations

import os

from ament_index_python.packages import get_package_share_directory
from launch.actions import DeclareLaunchArgument, SetEnvironmentVariable
from launch.conditions import IfCondition, UnlessCondition
from launch.substitutions import LaunchConfiguration, PythonExpression
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue

from launch import LaunchDescription

PROFILE_VARIABLE = 'FASTRTPS_DEFAULT_PROFILES_FILE'


def generate_launch_description() -> LaunchDescription:
    share = get_package_share_directory('human_tracker')
    image = LaunchConfiguration('image')
    target = LaunchConfiguration('target')
    single = LaunchConfiguration('single_process')
    hand = PythonExpression(["'", target, "' == 'hand'"])
    remappings = [
        ('image', image),
        ('image/compressed', [image, '/compressed']),
        ('camera_info', LaunchConfiguration('camera_info')),
    ]
    common = {
        'package': 'human_tracker',
        'namespace': LaunchConfiguration('namespace'),
        'parameters': [LaunchConfiguration('params_file')],
        'remappings': remappings,
        'output': 'screen',
    }
    return LaunchDescription(
        [
            DeclareLaunchArgument('image', default_value='/camera/image_raw', description='camera image topic'),
            DeclareLaunchArgument('camera_info', default_value='/camera/camera_info', description='camera_info topic'),
            DeclareLaunchArgument('namespace', default_value='', description='namespace of the nodes and their topics'),
            DeclareLaunchArgument(
                'params_file',
                default_value=os.path.join(share, 'config', 'human_tracker.yaml'),
                description='parameters file',
            ),
            DeclareLaunchArgument('target', default_value='head', description='head or hand'),
            DeclareLaunchArgument(
                'single_process', default_value='true', description='one process (pipeline) or one per node'
            ),
            # Camera frames between processes need a larger shared-memory segment than the
            # default; a profile the user already chose is kept.
            SetEnvironmentVariable(
                PROFILE_VARIABLE,
                os.environ.get(PROFILE_VARIABLE) or os.path.join(share, 'config', 'fastdds_large_shm.xml'),
            ),
            Node(
                executable='pipeline',
                condition=IfCondition(single),
                **{**common, 'parameters': [LaunchConfiguration('params_file'), {'target': target}]},
            ),
            Node(executable='background_node', condition=UnlessCondition(single), **common),
            Node(
                executable='skin_node',
                condition=IfCondition(PythonExpression(["'", single, "' != 'true' and ", hand])),
                **common,
            ),
            Node(
                executable='tracker_node',
                condition=UnlessCondition(single),
                **{
                    **common,
                    'parameters': [
                        LaunchConfiguration('params_file'),
                        {
                            'target': target,
                            'motion_input': 'foreground',
                            'skin_input': ParameterValue(hand, value_type=bool),
                        },
                    ],
                },
            ),
        ]
    )
