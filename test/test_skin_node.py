"""skin_node over real DDS: the core's labels per frame, grey input reported, adaptation from the contour."""

from __future__ import annotations

import time

import numpy as np
import rclpy
from geometry_msgs.msg import Point32, PolygonStamped
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image
from std_msgs.msg import Header

from human_tracker.ros.image_conversion import array_to_image, image_to_array
from human_tracker.ros.skin_node import SkinNode
from human_tracker.scenes.generator import SCENES, render_scene
from human_tracker.vision.cues.resolution import to_working
from human_tracker.vision.cues.skin import SkinSegmenter, default_skin_model

RELIABLE = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)


def test_skin_node_labels_colour_frames_and_reports_grey_ones() -> None:
    frames = list(render_scene(SCENES['hand_wave']))[:6]
    rclpy.init()
    overrides = [
        Parameter('qos_reliability', value='reliable'),
        Parameter('qos_depth', value=100),
        Parameter('adaptation_rate', value=0.2),
    ]
    node = SkinNode(parameter_overrides=overrides)
    source = Node('camera')
    images = source.create_publisher(Image, 'image', RELIABLE)
    contours = source.create_publisher(PolygonStamped, 'contour', RELIABLE)
    received: dict[int, np.ndarray] = {}
    source.create_subscription(
        Image, 'skin', lambda m: received.__setitem__(m.header.stamp.nanosec, image_to_array(m)), RELIABLE
    )
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    executor.add_node(source)
    try:
        deadline = time.monotonic() + 20.0
        while (images.get_subscription_count() < 1 or contours.get_subscription_count() < 1) and (
            time.monotonic() < deadline
        ):
            executor.spin_once(timeout_sec=0.05)
        # The tracker's contour: the true hand, as a polygon round its box.
        x, y, w, h = frames[0].box
        polygon = PolygonStamped()
        polygon.polygon.points = [Point32(x=px, y=py) for px, py in ((x, y), (x + w, y), (x + w, y + h), (x, y + h))]
        contours.publish(polygon)
        for _ in range(10):
            executor.spin_once(timeout_sec=0.02)
        for index, frame in enumerate(frames):
            images.publish(array_to_image(frame.image, 'bgr8', _header(index)))
        grey = frames[0].image.mean(axis=2).astype(np.uint8)
        images.publish(array_to_image(grey, 'mono8', _header(len(frames))))
        deadline = time.monotonic() + 30.0
        while len(received) < len(frames) + 1 and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        state, extra = node.diagnostics_state()
        warning_while_grey = node.warnings()
        # Colour again: the warning goes.
        images.publish(array_to_image(frames[1].image, 'bgr8', _header(len(frames) + 1)))
        deadline = time.monotonic() + 30.0
        while len(received) < len(frames) + 2 and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        warning_after = node.warnings()
    finally:
        executor.shutdown()
        node.destroy_node()
        source.destroy_node()
        rclpy.try_shutdown()
    assert sorted(received) == list(range(len(frames) + 2))
    # The first frame is labelled by the learnt classes, exactly as the core does, at the
    # working resolution (half the 640-pixel frame), with the parameters' lengths scaled.
    width = 320  # the node's default working_width
    expected = SkinSegmenter(default_skin_model()).segment(to_working(frames[0].image, width), 0.5)
    np.testing.assert_array_equal(received[0], expected)
    truth = to_working(frames[0].skin, width, mask=True)
    assert np.count_nonzero(received[0] & truth) > 0.85 * np.count_nonzero(truth)
    assert extra['adaptations'] == len(frames)  # the skin inside the contour adapted the classes
    assert not received[len(frames)].any() and extra['frames_grey'] == 1 and state == 'OK'
    # A grey frame is a warning in /diagnostics (WARN level) while grey frames come.
    assert len(warning_while_grey) == 1 and warning_while_grey[0].startswith('GREY_INPUT')
    assert warning_after == []


def _header(index: int) -> Header:
    header = Header(frame_id='camera_optical_frame')
    header.stamp.nanosec = index
    return header
