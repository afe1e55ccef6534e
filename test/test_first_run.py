"""The traps a new user fell into on a first run, each with the behaviour that replaces it."""

from __future__ import annotations

import ast
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numba
import numpy as np
import pytest
import rclpy
import yaml
from conftest import BAGS, REPO
from rclpy.node import Node
from rclpy.parameter import Parameter
from ros_harness import collecting, environment
from std_msgs.msg import Bool

from human_tracker.demo import demo_problems
from human_tracker.io.bags import COMPRESSED_CAMERA_TOPIC, read_frames
from human_tracker.ros.common import LATCHED_QOS, declare
from human_tracker.ros.image_conversion import array_to_image, message_to_bgr8
from human_tracker.ros.processes import NodeProcess
from human_tracker.ros.tracker_node import TrackerNode
from human_tracker.ros.video_publisher import VideoPublisher
from human_tracker.threads import ENVIRONMENT_VARIABLE, default_threads, use_threads
from human_tracker.vision.filter.contour_filter import TrackerParameters

CLI = [sys.executable, '-m', 'human_tracker.cli']
CONFIG = REPO / 'config' / 'human_tracker.yaml'


def _cli(*args: str, cwd: Path = REPO) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, cwd=cwd)


def _stamped(message, index: int):
    message.header.stamp.sec, message.header.stamp.nanosec = 100, index * 1_000_000
    return message


# Readiness --------------------------------------------------------------------------------


def test_a_stage_says_ready_once_spinning_and_warmed_up() -> None:
    """``~/ready`` is latched: a subscriber that comes later still learns it."""
    rclpy.init()
    tracker = TrackerNode(parameter_overrides=[Parameter('target', value='hand')])
    listener = Node('ready_listener')
    said: list[bool] = []
    try:
        assert not tracker.ready
        executor = rclpy.executors.SingleThreadedExecutor()
        executor.add_node(tracker)
        executor.add_node(listener)
        deadline = time.monotonic() + 60.0
        while not tracker.ready and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        listener.create_subscription(Bool, '/tracker_node/ready', lambda m: said.append(m.data), LATCHED_QOS)
        while not said and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        extra = tracker.diagnostics_state()
    finally:
        executor.shutdown()
        tracker.destroy_node()
        listener.destroy_node()
        rclpy.try_shutdown()
    assert tracker.ready and said == [True]
    assert extra[0] == 'WAITING'


SKIN_KERNELS = {
    'cues.skin.model': ('_nearest_class',),
    'cues.skin.regions': ('_distance_levels',),
    'cues.skin.clusters': ('_modes', '_region_histograms', '_cluster_statistics', '_two_means'),
}


@pytest.mark.parametrize(
    ('node', 'target', 'kernels'),
    [
        ('skin_node.SkinNode', None, SKIN_KERNELS),
        (
            'tracker_node.TrackerNode',
            'head',
            {'filter.measurement': ('_contour_costs',), 'filter.proposals': ('_log_mixture',)},
        ),
        (
            'tracker_node.TrackerNode',
            'hand',
            {
                'filter.measurement': ('_contour_costs', '_colour_costs'),
                'cues.edges': ('_strongest_channel',),
                'filter.proposals': ('_log_mixture',),
            },
        ),
    ],
)
def test_warm_up_compiles_the_kernels_frames_need(node, target, kernels, tmp_path) -> None:
    """A node says it is ready once warmed up, so the warm-up must run the compiled kernels of
    its stage, or the first real frames wait for their compilation: a random frame has no skin
    region (23 frames without skin at the tracker, over DDS) and no detection to draw particles
    around. In a fresh process with an empty kernel cache, as on a robot's first run."""
    module, name = node.split('.')
    overrides = '' if target is None else f"parameter_overrides=[Parameter('target', value='{target}')]"
    script = (
        'import importlib, rclpy\n'
        'from rclpy.parameter import Parameter\n'
        f'from human_tracker.ros.{module} import {name}\n'
        'rclpy.init()\n'
        f'{name}({overrides}).warm_up()\n'
        f'print([(m, k) for m, ks in {kernels!r}.items() for k in ks'
        " if not getattr(importlib.import_module(f'human_tracker.vision.{m}'), k).signatures])\n"
    )
    environment = {**os.environ, 'NUMBA_CACHE_DIR': str(tmp_path)}
    done = subprocess.run(
        [sys.executable, '-c', script], env=environment, capture_output=True, text=True, timeout=300, check=True
    )
    assert done.stdout.strip().splitlines()[-1] == '[]', done.stdout + done.stderr


def test_a_replay_waits_for_a_tracker_that_is_still_compiling(head_bag, tmp_path) -> None:
    """The first-run failure: the bag played while tracker_node compiled and 20 frames were lost.

    Here the tracker compiles from an empty numba cache and the player is started with it;
    with ``--wait-for-ready`` every one of the 120 frames is tracked from the first-frame box.
    """
    frames = list(read_frames(head_bag))
    env = {**environment(), 'NUMBA_CACHE_DIR': str(tmp_path / 'numba_cache')}
    box = frames[0].ground_truth
    tracker = NodeProcess(
        'human_tracker.ros.tracker_node',
        [
            '--ros-args',
            '-p',
            'image_transport:=compressed',
            '-p',
            'qos_reliability:=reliable',
            '-p',
            'qos_depth:=100',
            '-p',
            'init_box:=[' + ', '.join(f'{v:.2f}' for v in box) + ']',
            '-r',
            f'image/compressed:={COMPRESSED_CAMERA_TOPIC}',
        ],
        env,
        tmp_path / 'tracker.log',
    )
    player = NodeProcess(
        'human_tracker.ros.bag_play',
        [
            str(head_bag),
            # At the camera's rate: at 4x, with a third CPU-bound process beside make test's two
            # workers, 114 poses of 120 came back. The poses are published keep-last 10, and a
            # collector starved of CPU may fall that far behind a burst.
            '--rate',
            '1',
            '--wait-for-subscribers',
            COMPRESSED_CAMERA_TOPIC,
            '1',
            '--wait-for-ready',
            '/tracker_node',
        ],
        environment(),
        tmp_path / 'bag_play.log',
    )
    with collecting() as (collector, executor):
        try:
            tracker.start()
            player.start()
            deadline = time.monotonic() + 180.0
            while len(collector.poses) < len(frames) and time.monotonic() < deadline:
                executor.spin_once(timeout_sec=0.05)
            assert player.wait(30.0) == 0, player.output()
        finally:
            tracker.stop()
            player.stop()
    assert len(collector.poses) == len(frames), tracker.output() + player.output()
    assert 'warmed up in' in tracker.output() and 'ready' in tracker.output().split('warmed up in')[-1]


def test_the_demo_fails_on_missing_poses_or_low_precision() -> None:
    good = {'poses_received': 120, 'frames': 120, 'precision_20px': 1.0}
    assert demo_problems(good, 0.95) == []
    assert demo_problems({**good, 'poses_received': 100}, 0.95) == ['100 poses for 120 frames']
    assert demo_problems({**good, 'precision_20px': 0.242}, 0.95) == ['precision at 20 px 0.242 < 0.95']


def test_masks_of_frames_tracked_long_ago_are_not_counted_as_never_received() -> None:
    """A cue stage that lags (compiling) sends its masks after the tracker tracked their frames.

    60 frames are tracked without their masks (they waited out match_timeout); then all 60
    masks arrive. None of those frames was lost: frames_never_received stays 0. Then the mask
    of a frame that never reached the tracker is counted.
    """
    frame = message_to_bgr8(next(iter(read_frames(str(BAGS / 'head_basic')))).message)
    rclpy.init()
    overrides = [Parameter('motion_input', value='foreground'), Parameter('match_timeout', value=0.0)]
    node = TrackerNode(parameter_overrides=overrides)
    try:
        for index in range(60):
            node.on_image(_stamped(array_to_image(frame, 'bgr8'), index))
        for index in range(60):
            node.inputs.on_mask('foreground', _stamped(array_to_image(np.zeros((240, 320), np.uint8), 'mono8'), index))
        before = node.diagnostics_state()[1]['frames_never_received']
        node.inputs.on_mask('foreground', _stamped(array_to_image(np.zeros((240, 320), np.uint8), 'mono8'), 61))
        node.on_image(_stamped(array_to_image(frame, 'bgr8'), 62))
        node.inputs.drain()
        after = node.diagnostics_state()[1]['frames_never_received']
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    assert node.counters.processed == 61
    assert (before, after) == (0, 1)


# Nothing shipped is overwritten ---------------------------------------------------------------


def test_train_skin_and_generate_write_only_where_told(tmp_path) -> None:
    shipped = REPO / 'human_tracker' / 'data' / 'skin_model.json'
    digest = hashlib.sha256(shipped.read_bytes()).hexdigest()
    samples = tmp_path / 'samples.txt'
    samples.write_text('\n'.join(['120 150 200 1', '40 200 60 2'] * 20) + '\n')
    for args in (['train-skin', str(samples)], ['generate', '--all']):
        result = _cli(*args)
        assert result.returncode == 2 and '--out' in result.stderr
        result = _cli(*args, cwd=tmp_path)
        assert result.returncode == 2 and '--out' in result.stderr
    assert hashlib.sha256(shipped.read_bytes()).hexdigest() == digest
    assert not (tmp_path / 'human_tracker').exists() and not (tmp_path / 'bags').exists()


# Parameters -------------------------------------------------------------------------------------


def test_min_scale_above_max_scale_is_refused_at_start_and_at_run_time() -> None:
    with pytest.raises(ValueError, match='min_scale <= max_scale'):
        TrackerParameters(min_scale=50.0, max_scale=40.0).validate()
    rclpy.init()
    try:
        with pytest.raises(ValueError, match='min_scale <= max_scale'):
            TrackerNode(parameter_overrides=[Parameter('min_scale', value=3000.0)])
        node = TrackerNode()
        result = node.set_parameters([Parameter('max_scale', value=10.0)])[0]
        kept = node.get_parameter('max_scale').value
        node.destroy_node()
    finally:
        rclpy.try_shutdown()
    assert not result.successful and 'min_scale <= max_scale' in result.reason
    assert kept == 2000.0


@pytest.mark.parametrize(
    ('overrides', 'problem'),
    [
        ([], 'init_region is motion but no motion input'),
        ([Parameter('target', value='hand')], 'init_region is skin but no skin input'),
        ([Parameter('motion_input', value='foreground')], None),
        ([Parameter('init_box', value=[10.0, 10.0, 50.0, 60.0])], None),
    ],
)
def test_a_tracker_that_cannot_start_by_itself_says_so(overrides: list[Parameter], problem: str | None) -> None:
    rclpy.init()
    try:
        node = TrackerNode(parameter_overrides=overrides)
        extra = node.diagnostics_state()[1]
        node.destroy_node()
    finally:
        rclpy.try_shutdown()
    if problem is None:
        assert 'cannot_start' not in extra
    else:
        assert problem in extra['cannot_start']


def test_an_init_box_outside_the_image_is_reported_and_ignored() -> None:
    frame = message_to_bgr8(next(iter(read_frames(str(BAGS / 'head_basic')))).message)
    rclpy.init()
    try:
        node = TrackerNode(parameter_overrides=[Parameter('init_box', value=[5000.0, 5000.0, 10.0, 10.0])])
        node.on_image(_stamped(array_to_image(frame, 'bgr8'), 0))
        extra = node.diagnostics_state()
        node.destroy_node()
    finally:
        rclpy.try_shutdown()
    assert extra[0] == 'WAITING' and 'outside the 640x480 image' in extra[1]['cannot_start']


def test_integers_are_taken_for_doubles_and_strings() -> None:
    """``-p init_box:="[1, 2, 3, 4]"``, ``-p likelihood_gain:=1`` and ``-p source:=0`` mean what they say."""
    rclpy.init(
        args=['x', '--ros-args', '-p', 'init_box:=[1, 2, 30, 40]', '-p', 'likelihood_gain:=1', '-p', 'source:=0']
    )
    try:
        tracker = TrackerNode()
        publisher = VideoPublisher()
        changed = tracker.set_parameters([Parameter('process_noise', value=[4, 4, 0, 0])])[0]
        values = (
            tracker.init_box,
            tracker.tracker.filter.parameters.likelihood_gain,
            tracker.tracker.filter.parameters.process_noise,
            publisher.source_name,
        )
        wrong = tracker.set_parameters([Parameter('likelihood_gain', value='a lot')])[0]
        tracker.destroy_node()
        publisher.destroy_node()
    finally:
        rclpy.try_shutdown()
    assert changed.successful
    assert values == ((1.0, 2.0, 30.0, 40.0), 1.0, (4.0, 4.0, 0.0, 0.0), '0')
    assert not wrong.successful


def test_a_command_line_parameter_after_the_params_file_wins() -> None:
    """ROS applies ``--params-file`` and ``-p`` in their order: the README puts the file first."""
    rclpy.init(args=['x', '--ros-args', '--params-file', str(CONFIG), '-p', 'motion_cue:=flow'])
    try:
        node = Node('pipeline')
        value = declare(node, 'motion_cue', 'background', 'motion cue')
        node.destroy_node()
    finally:
        rclpy.try_shutdown()
    assert value == 'flow'
    readme = (REPO / 'README.md').read_text().replace('\\\n', ' ')  # continuation lines joined
    commands = re.findall(r'ros2 (?:run|launch) [^\n]*', readme)
    assert any('--params-file' in command for command in commands)
    for command in commands:
        if '--params-file' in command:
            assert ' -p ' not in command.split('--params-file')[0], command


def test_the_launch_file_keeps_a_fast_dds_profile_the_user_chose() -> None:
    """``launch`` is not installable here: read what the launch file sets the variable to."""
    tree = ast.parse((REPO / 'launch' / 'human_tracker.launch.py').read_text())
    calls = [
        n for n in ast.walk(tree) if isinstance(n, ast.Call) and getattr(n.func, 'id', '') == 'SetEnvironmentVariable'
    ]
    assert len(calls) == 1
    value = ast.unparse(calls[0].args[1])
    assert value.startswith('os.environ.get(PROFILE_VARIABLE) or'), value


def test_the_launch_file_opens_the_shipped_rviz_view_when_asked() -> None:
    """``rviz:=true`` runs rviz2 on config/human_tracker.rviz, fixed on ``camera_frame``; off by default."""
    source = (REPO / 'launch' / 'human_tracker.launch.py').read_text()
    tree = ast.parse(source)
    declared = {
        n.args[0].value: n
        for n in ast.walk(tree)
        if isinstance(n, ast.Call) and getattr(n.func, 'id', '') == 'DeclareLaunchArgument'
    }
    assert {'rviz', 'camera_frame'} <= set(declared)
    assert ast.literal_eval(next(k.value for k in declared['rviz'].keywords if k.arg == 'default_value')) == 'false'
    rviz2 = [
        n
        for n in ast.walk(tree)
        if isinstance(n, ast.Call)
        and getattr(n.func, 'id', '') == 'Node'
        and any(k.arg == 'executable' and ast.literal_eval(k.value) == 'rviz2' for k in n.keywords)
    ]
    assert len(rviz2) == 1
    arguments = ast.unparse(next(k.value for k in rviz2[0].keywords if k.arg == 'arguments'))
    assert "'human_tracker.rviz'" in arguments and "LaunchConfiguration('camera_frame')" in arguments
    assert ast.unparse(next(k.value for k in rviz2[0].keywords if k.arg == 'condition')) == 'IfCondition(rviz)'
    view = yaml.safe_load((REPO / 'config' / 'human_tracker.rviz').read_text())
    displays = {d['Class']: d for d in view['Visualization Manager']['Displays']}
    # The targets' TF frames (face_<id>, hand_<id>) are drawn and named.
    assert displays['rviz_default_plugins/TF']['Show Names'] is True
    assert {'rviz_default_plugins/MarkerArray', 'rviz_default_plugins/Image'} <= set(displays)


# Offline command ----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ('args', 'says'),
    [
        (
            ['track', str(BAGS / 'head_basic'), '--init', '5000,5000,10,10', '--no-video', '--quiet'],
            'outside the 640x480',
        ),
        (['import', str(BAGS / 'head_basic'), '--out', '/tmp/never', '--target', 'face'], "invalid choice: 'face'"),
        (['eval', str(REPO / 'README.md'), str(BAGS / 'head_basic')], 'is not a poses.csv written by `track`'),
    ],
)
def test_offline_mistakes_are_refused_with_the_reason(args: list[str], says: str, tmp_path) -> None:
    args = [a if a != '/tmp/never' else str(tmp_path / 'never') for a in args]
    result = _cli(*args, '--out', str(tmp_path / 'out')) if args[0] == 'track' else _cli(*args)
    assert result.returncode == 2, result.stdout
    assert says in result.stderr and 'Traceback' not in result.stderr


def test_a_bare_mcap_file_is_a_bag(head_bag, tmp_path) -> None:
    bare = tmp_path / 'recording.mcap'
    shutil.copy(head_bag / 'head_basic.mcap', bare)
    frames = list(read_frames(bare))
    assert len(frames) == 120 and frames[0].ground_truth is not None
    result = _cli('track', str(bare), '--no-video', '--quiet', '--out', str(tmp_path / 'out'))
    assert result.returncode == 0, result.stderr
    summary = json.loads((tmp_path / 'out' / 'summary.json').read_text())
    assert summary['frames_processed'] == 120 and summary['precision_20px'] > 0.9


# video_publisher and bag_play ---------------------------------------------------------------------


def test_video_publisher_waits_for_image_subscribers_answers_parameters_and_reports(tmp_path) -> None:
    """An image subscriber alone starts it; its parameter service answers; it publishes /diagnostics."""
    folder = tmp_path / 'frames'
    folder.mkdir()
    import cv2

    for i in range(3):
        cv2.imwrite(str(folder / f'{i:04d}.png'), np.full((48, 64, 3), 40 * i, np.uint8))
    args = ['--ros-args', '-p', f'source:={folder}', '-p', 'rate:=20.0', '-p', 'loop:=true']
    publisher = NodeProcess(
        'human_tracker.ros.video_publisher', [*args, '-p', 'wait_for_subscribers:=1'], environment(), tmp_path / 'log'
    )
    from rcl_interfaces.srv import GetParameters
    from sensor_msgs.msg import Image

    with collecting() as (collector, executor):
        images: list[Image] = []
        collector.create_subscription(Image, 'image_raw', images.append, 10)
        client = collector.create_client(GetParameters, '/video_publisher/get_parameters')
        try:
            publisher.start()
            started = time.monotonic()
            while not images and time.monotonic() - started < 25.0:
                executor.spin_once(timeout_sec=0.05)
            waited = time.monotonic() - started
            assert client.wait_for_service(timeout_sec=10.0)
            future = client.call_async(GetParameters.Request(names=['rate']))
            executor.spin_until_future_complete(future, timeout_sec=10.0)
            status = collector.spin_until_diagnostics(executor, '/video_publisher', 5.0)
        finally:
            publisher.stop()
    assert images and waited < 20.0, publisher.output()
    assert future.result() is not None and future.result().values[0].double_value == 20.0
    assert status['state'] == 'PUBLISHING' and int(status['frames_published']) >= 1


def test_bag_play_reports_on_diagnostics(head_bag, tmp_path) -> None:
    player = NodeProcess('human_tracker.ros.bag_play', [str(head_bag), '--loop'], environment(), tmp_path / 'log')
    with collecting() as (collector, executor):
        try:
            player.start()
            status = collector.spin_until_diagnostics(executor, '/bag_play', 20.0)
        finally:
            player.stop()
    assert status['state'] in ('PLAYING', 'WAITING_FOR_NODES', 'STARTING'), player.output()
    assert 'messages_published' in status


# Threads ------------------------------------------------------------------------------------------


def test_thread_policy(monkeypatch) -> None:
    monkeypatch.delenv(ENVIRONMENT_VARIABLE, raising=False)
    assert default_threads() == 1
    monkeypatch.setenv(ENVIRONMENT_VARIABLE, '0')
    assert default_threads() == 0
    monkeypatch.setenv(ENVIRONMENT_VARIABLE, 'many')
    with pytest.raises(ValueError, match=ENVIRONMENT_VARIABLE):
        default_threads()
    try:
        assert use_threads(1) == 1 and numba.get_num_threads() == 1
        assert use_threads(0) == numba.config.NUMBA_NUM_THREADS == numba.get_num_threads()
    finally:
        use_threads(1)
