"""bag_play over real DDS: recorded QoS, --topics, --remap, --start-paused, --start-offset,
~/pause and ~/resume."""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from ros_harness import environment
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2 import StoragePlugin, Writer
from sensor_msgs.msg import Image
from std_srvs.srv import Trigger

from human_tracker.io.bags import TYPESTORE
from human_tracker.ros.processes import NodeProcess
from human_tracker.scenes.generator import SCENES, render_scene

SMALL = dataclasses.replace(SCENES['head_basic'], width=160, height=120, head_width=24, num_frames=8)
BEST_EFFORT = Qos(
    QosHistory.KEEP_LAST, 5, QosReliability.BEST_EFFORT, QosDurability.VOLATILE,
    QosTime(0, 0), QosTime(0, 0), QosLiveliness.AUTOMATIC, QosTime(0, 0), False,
)  # fmt: skip


def _write_bag(path) -> list[int]:
    """A sqlite3 bag: raw frames on /cam/image (recorded best effort) and a /cam/other topic."""
    types = TYPESTORE.types
    stamps = []
    with Writer(path, version=9, storage_plugin=StoragePlugin.SQLITE3) as writer:
        image = writer.add_connection(
            '/cam/image', 'sensor_msgs/msg/Image', typestore=TYPESTORE, offered_qos_profiles=[BEST_EFFORT]
        )
        other = writer.add_connection('/cam/other', 'std_msgs/msg/String', typestore=TYPESTORE)
        for frame in render_scene(SMALL):
            stamp = types['builtin_interfaces/msg/Time'](sec=frame.stamp_ns // 10**9, nanosec=frame.stamp_ns % 10**9)
            header = types['std_msgs/msg/Header'](stamp=stamp, frame_id='cam')
            msg = types['sensor_msgs/msg/Image'](
                header=header,
                height=120,
                width=160,
                encoding='bgr8',
                is_bigendian=0,
                step=480,
                data=frame.image.reshape(-1),
            )
            writer.write(image, frame.stamp_ns, TYPESTORE.serialize_cdr(msg, 'sensor_msgs/msg/Image'))
            writer.write(
                other,
                frame.stamp_ns,
                TYPESTORE.serialize_cdr(types['std_msgs/msg/String'](data='x'), 'std_msgs/msg/String'),
            )
            stamps.append(frame.stamp_ns)
    return stamps


def _stamps_on(node: Node, topic: str) -> list[int]:
    """The stamps (ns) of the images ``node`` receives on ``topic`` from now on, in order."""
    received: list[int] = []
    node.create_subscription(
        Image,
        topic,
        lambda m: received.append(m.header.stamp.sec * 10**9 + m.header.stamp.nanosec),
        QoSProfile(depth=50, reliability=ReliabilityPolicy.BEST_EFFORT),
    )
    return received


def test_start_paused_resume_topics_remap_and_recorded_qos(tmp_path) -> None:
    stamps = _write_bag(tmp_path / 'bag')
    args = [str(tmp_path / 'bag'), '--start-paused', '--topics', '/cam/image', '--remap', '/cam/image:=/renamed/image']
    player = NodeProcess('human_tracker.ros.bag_play', args, environment(), tmp_path / 'bag_play.log').start()
    rclpy.init()
    node = Node('bag_play_test')
    received = _stamps_on(node, '/renamed/image')
    resume = node.create_client(Trigger, '/bag_play/resume')
    try:
        assert resume.wait_for_service(timeout_sec=30.0), player.output()
        deadline = time.monotonic() + 2.0
        while time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.05)
        assert received == []  # paused: nothing is published
        publishers = node.get_publishers_info_by_topic('/renamed/image')
        assert len(publishers) == 1
        assert publishers[0].qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT  # as recorded
        assert node.get_publishers_info_by_topic('/cam/other') == []  # filtered out by --topics
        future = resume.call_async(Trigger.Request())
        rclpy.spin_until_future_complete(node, future, timeout_sec=10.0)
        assert future.result().success
        deadline = time.monotonic() + 20.0
        while len(received) < len(stamps) and time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.05)
        assert player.wait(20.0) == 0, player.output()
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        player.stop()
    assert received == stamps
    assert np.all(np.diff(received) > 0)


def test_start_offset_skips_the_bag_s_beginning_and_pause_holds_the_rest(tmp_path) -> None:
    """--start-offset 0.09 s: the frames from 0.1 s on (frames 3-7); at a tenth of the rate, a
    pause after two of them publishes nothing for a second, then resume plays the rest."""
    stamps = _write_bag(tmp_path / 'bag')
    args = [
        str(tmp_path / 'bag'),
        '--start-offset',
        '0.09',
        '--rate',
        '0.1',
        '--topics',
        '/cam/image',
        '--start-paused',
    ]
    player = NodeProcess('human_tracker.ros.bag_play', args, environment(), tmp_path / 'bag_play.log')
    rclpy.init()
    node = Node('bag_play_test')
    received = _stamps_on(node, '/cam/image')
    pause, resume = (node.create_client(Trigger, f'/bag_play/{name}') for name in ('pause', 'resume'))

    def spin(seconds: float, until=lambda: False) -> None:
        deadline = time.monotonic() + seconds
        while not until() and time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.02)

    try:
        player.start()
        assert pause.wait_for_service(timeout_sec=30.0) and resume.wait_for_service(timeout_sec=30.0)
        future = resume.call_async(Trigger.Request())
        rclpy.spin_until_future_complete(node, future, timeout_sec=10.0)
        spin(30.0, lambda: len(received) >= 2)
        future = pause.call_async(Trigger.Request())
        rclpy.spin_until_future_complete(node, future, timeout_sec=10.0)
        assert future.result().success
        spin(0.05)  # a frame on its way when the pause came
        held = len(received)
        spin(1.0)
        during_pause = len(received) - held
        future = resume.call_async(Trigger.Request())
        rclpy.spin_until_future_complete(node, future, timeout_sec=10.0)
        spin(30.0, lambda: len(received) >= len(stamps) - 3)
        assert player.wait(20.0) == 0, player.output()
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        player.stop()
    assert during_pause == 0
    assert received == stamps[3:]


def test_missing_bag_is_a_clear_error(tmp_path) -> None:
    player = NodeProcess(
        'human_tracker.ros.bag_play', [str(tmp_path / 'nope')], environment(), tmp_path / 'log'
    ).start()
    assert player.wait(30.0) == 1
    assert 'bag_play: error:' in player.output() and 'does not exist' in player.output()
    assert 'Traceback' not in player.output()
