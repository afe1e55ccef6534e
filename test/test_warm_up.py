"""A node says ready only once the kernels its frames need are compiled: the first frames after
``ready`` are processed in ordinary time, also on a first run with an empty kernel cache."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import rclpy
from conftest import BAGS
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from ros_harness import environment
from sensor_msgs.msg import Image
from std_msgs.msg import Bool

from human_tracker.io.bags import read_frames
from human_tracker.ros.common import LATCHED_QOS
from human_tracker.ros.image_conversion import array_to_image, message_to_bgr8
from human_tracker.ros.processes import NodeProcess

# In a fresh process: build the pipeline's nodes as `pipeline` does, warm them up, then feed
# real frames through the camera subscriber; print the compiled kernels that gained a
# signature after the warm-up (each would have compiled while frames waited).
_NEW_KERNELS = """
import importlib, json, pkgutil, sys
import rclpy
from numba.core.registry import CPUDispatcher
import human_tracker.vision as vision
from human_tracker.io.bags import read_frames
from human_tracker.ros.image_conversion import message_to_bgr8
from human_tracker.ros.pipeline import build_pipeline

def signatures():
    found = {}
    for info in pkgutil.walk_packages(vision.__path__, 'human_tracker.vision.'):
        module = importlib.import_module(info.name)
        for name, value in vars(module).items():
            if isinstance(value, CPUDispatcher) and value.__module__ == module.__name__:
                found[f'{info.name}.{name}'] = {str(s) for s in value.signatures}
    return found

bag, count, ros_args = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
rclpy.init(args=['pipeline', '--ros-args', *ros_args])
nodes = build_pipeline()
camera = nodes[1]
camera.warm_up()
before = signatures()
for frame in list(read_frames(bag))[:count]:
    camera.process_frame(message_to_bgr8(frame.message), frame.message.header)
after = signatures()
print(json.dumps({'kernels': len(after), 'new': sorted(k for k in after if after[k] - before.get(k, set()))}))
"""


@pytest.mark.parametrize(
    ('bag', 'parameters'),
    [
        ('people_crossing', ['target:=person', 'max_people:=2']),
        ('hand_wave', ['target:=person', 'hands:=2', 'motion_cue:=flow']),
        ('head_basic', ['target:=head']),
    ],
)
def test_the_pipeline_s_warm_up_reaches_every_kernel_its_frames_need(bag: str, parameters: list[str]) -> None:
    args = [arg for p in parameters for arg in ('-p', p)]
    done = subprocess.run(
        [sys.executable, '-c', _NEW_KERNELS, str(BAGS / bag), '60', *args],
        capture_output=True,
        text=True,
        timeout=600,
        env=environment(),
    )
    assert done.returncode == 0, done.stderr[-3000:]
    found = json.loads(done.stdout.strip().splitlines()[-1])
    assert found['kernels'] >= 10 and found['new'] == [], done.stdout  # every compiled kernel of vision/ seen


@pytest.mark.timed
def test_a_cold_person_pipeline_keeps_up_from_its_first_frame_after_ready(tmp_path: Path) -> None:
    """An empty kernel cache (a robot's first run): the pipeline says ready, then each of its
    first 30 frames (sent at 10 Hz, stamped when sent) comes back on debug_image within 200 ms."""
    env = {**environment(), 'NUMBA_CACHE_DIR': str(tmp_path / 'numba')}
    frames = [message_to_bgr8(f.message) for f in list(read_frames(BAGS / 'people_crossing'))[:30]]
    pipeline = NodeProcess(
        'human_tracker.ros.pipeline',
        ['--ros-args', '-p', 'target:=person', '-p', 'qos_reliability:=reliable', '-p', 'qos_depth:=30'],
        env,
        tmp_path / 'pipeline.log',
    )
    reliable = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
    ages: dict[int, float] = {}
    with pipeline:
        rclpy.init()
        node = Node('camera')
        try:
            ready: list[bool] = []
            node.create_subscription(Bool, '/camera_subscriber/ready', lambda m: ready.append(m.data), LATCHED_QOS)

            def on_debug(msg: Image) -> None:
                sent = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
                ages[msg.header.frame_id.count('x')] = (time.time_ns() - sent) / 1e9
                # frame_id carries the frame's index as a count of 'x' (any frame_id is copied)

            node.create_subscription(Image, 'debug_image', on_debug, reliable)
            images = node.create_publisher(Image, 'image', reliable)
            deadline = time.monotonic() + 300
            while not ready and time.monotonic() < deadline and pipeline.process.poll() is None:
                rclpy.spin_once(node, timeout_sec=0.1)
            assert ready, pipeline.output()[-3000:]
            while images.get_subscription_count() < 1 and time.monotonic() < deadline:
                rclpy.spin_once(node, timeout_sec=0.05)
            for index, image in enumerate(frames):
                message = array_to_image(image, 'bgr8')
                message.header.frame_id = 'x' * index
                now = time.time_ns()
                message.header.stamp.sec, message.header.stamp.nanosec = divmod(now, 10**9)
                images.publish(message)
                until = time.monotonic() + 1 / 10
                while time.monotonic() < until:
                    rclpy.spin_once(node, timeout_sec=0.005)
            deadline = time.monotonic() + 10
            while len(ages) < len(frames) and time.monotonic() < deadline:
                rclpy.spin_once(node, timeout_sec=0.05)
        finally:
            node.destroy_node()
            rclpy.try_shutdown()
    assert sorted(ages) == list(range(len(frames))), pipeline.output()[-3000:]
    worst = max(ages, key=ages.get)
    median = np.median(list(ages.values()))
    print(f'ages of the first frames after ready: median {median:.3f} s, worst {ages[worst]:.3f} s')
    assert ages[worst] < 0.2, f'frame {worst} came back {ages[worst]:.3f} s after it was sent'
