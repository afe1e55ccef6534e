"""Launch the tracker on a robot's camera.

ros2 launch human_tracker human_tracker.launch.py image:=/camera/color/image_raw
    [camera_info:=/camera/color/camera_info] [namespace:=head_tracker] [target:=head|hand|person]
    [params_file:=/path/to/human_tracker.yaml] [single_process:=true]
    [rviz:=true] [camera_frame:=camera_color_optical_frame]

With ``target:=hand`` (or ``person``) the skin stage runs too (in process, or as ``skin_node``). With
``rviz:=true`` RViz opens the package's view (``config/human_tracker.rviz``: the target's
contour and label, the annotated frame) in the nodes' namespace, fixed on ``camera_frame``,
the image's optical frame; where rviz2 is not installed, the launch says so and goes on.
"""

from __future__ import annotations

import os
import shutil

from ament_index_python.packages import PackageNotFoundError, get_package_share_directory
from launch.actions import DeclareLaunchArgument, LogInfo, SetEnvironmentVariable
from launch.conditions import IfCondition, UnlessCondition
from launch.substitutions import LaunchConfiguration, PythonExpression
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue

from launch import LaunchDescription

PROFILE_VARIABLE = 'FASTRTPS_DEFAULT_PROFILES_FILE'


def _rviz_installed() -> bool:
    try:
        get_package_share_directory('rviz2')
    except PackageNotFoundError:
        return shutil.which('rviz2') is not None
    return True


def generate_launch_description() -> LaunchDescription:
    share = get_package_share_directory('human_tracker')
    image = LaunchConfiguration('image')
    target = LaunchConfiguration('target')
    single = LaunchConfiguration('single_process')
    hand = PythonExpression(["'", target, "' in ('hand', 'person')"])
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
    rviz = LaunchConfiguration('rviz')
    if _rviz_installed():
        viewer = Node(
            package='rviz2',
            executable='rviz2',
            namespace=LaunchConfiguration('namespace'),
            arguments=[
                '-d',
                os.path.join(share, 'config', 'human_tracker.rviz'),
                '-f',
                LaunchConfiguration('camera_frame'),
            ],
            condition=IfCondition(rviz),
            output='screen',
        )
    else:
        viewer = LogInfo(
            msg='rviz:=true but rviz2 is not installed (apt install ros-jazzy-rviz2)', condition=IfCondition(rviz)
        )
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
            DeclareLaunchArgument('target', default_value='head', description='head, hand or person'),
            DeclareLaunchArgument(
                'single_process', default_value='true', description='one process (pipeline) or one per node'
            ),
            DeclareLaunchArgument('rviz', default_value='false', description='open RViz on the tracker (if installed)'),
            DeclareLaunchArgument(
                'camera_frame', default_value='camera_optical_frame', description="the image's optical frame (RViz)"
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
            viewer,
        ]
    )
