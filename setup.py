"""ament_python build of human_tracker (colcon on a robot, pip in a virtualenv)."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'human_tracker'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
        (f'share/{PACKAGE}/launch', glob('launch/*.launch.py')),
        (f'share/{PACKAGE}/config', glob('config/*.yaml') + glob('config/*.xml') + glob('config/*.rviz')),
    ],
    package_data={'human_tracker': ['data/*.json', 'data/*.onnx', 'data/*.md', 'data/*.LICENSE']},
    install_requires=['setuptools'],
    extras_require={'test': ['pytest']},
    zip_safe=True,
    maintainer='human_tracker developers',
    maintainer_email='dev@human-tracker.invalid',
    description='Visual tracking of head and hand silhouettes for human-robot interaction.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            f'tracker_node = {PACKAGE}.ros.tracker_node:main',
            f'pipeline = {PACKAGE}.ros.pipeline:main',
            f'background_node = {PACKAGE}.ros.background_node:main',
            f'optical_flow_node = {PACKAGE}.ros.optical_flow_node:main',
            f'skin_node = {PACKAGE}.ros.skin_node:main',
            f'bag_play = {PACKAGE}.ros.bag_play:main',
            f'video_publisher = {PACKAGE}.ros.video_publisher:main',
            f'human_tracker = {PACKAGE}.cli:main',
        ],
    },
)
