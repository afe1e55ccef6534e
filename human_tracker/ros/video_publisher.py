"""``video_publisher``: a camera device, video file or folder of frames to ``image_raw`` + ``camera_info``.

Frames are stamped with the time they are published and ``frame_id`` (the camera's optical
frame). ``camera_info`` comes from a calibration file in the ROS camera_calibration YAML
format, or is the documented default (ideal pinhole, 60° horizontal field of view). The node
spins while it publishes (parameter services answer) and reports on ``/diagnostics``.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import rclpy
import yaml
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CameraInfo, Image

from human_tracker.io.frames import FrameSourceError, open_frames
from human_tracker.ros.common import RESULT_QOS, declare, node_status, publish_diagnostics
from human_tracker.ros.image_conversion import array_to_image
from human_tracker.ros.run import run_nodes
from human_tracker.vision.geometry.camera import default_camera_matrix

__all__ = ['VideoPublisher', 'camera_info_from_file', 'default_camera_info', 'main']


def default_camera_info(width: int, height: int) -> CameraInfo:
    """CameraInfo of the default pinhole camera (60° horizontal field of view, no distortion)."""
    k = default_camera_matrix(width, height)
    info = CameraInfo(width=width, height=height, distortion_model='plumb_bob')
    info.d = [0.0] * 5
    info.k = k.reshape(-1).tolist()
    info.r = np.eye(3).reshape(-1).tolist()
    info.p = np.hstack([k, np.zeros((3, 1))]).reshape(-1).tolist()
    return info


def camera_info_from_file(path: str | Path) -> CameraInfo:
    """CameraInfo from a camera_calibration YAML file (``image_width``, ``camera_matrix``, ...).

    Raises:
        ValueError: The file is missing or malformed; the message says which.
    """
    try:
        spec = yaml.safe_load(Path(path).read_text())
        info = CameraInfo(width=int(spec['image_width']), height=int(spec['image_height']))
        info.distortion_model = str(spec.get('distortion_model', 'plumb_bob'))
        info.k = [float(v) for v in spec['camera_matrix']['data']]
        info.d = [float(v) for v in spec.get('distortion_coefficients', {}).get('data', [0.0] * 5)]
        info.r = [float(v) for v in spec.get('rectification_matrix', {}).get('data', np.eye(3).reshape(-1).tolist())]
        projection = spec.get('projection_matrix', {}).get('data')
        info.p = (
            [float(v) for v in projection] if projection else [*info.k[:3], 0.0, *info.k[3:6], 0.0, *info.k[6:9], 0.0]
        )
    except (OSError, yaml.YAMLError, KeyError, TypeError, ValueError) as err:
        raise ValueError(f'cannot read camera calibration {path}: {err}') from err
    if len(info.k) != 9 or len(info.p) != 12:
        raise ValueError(f'camera calibration {path}: camera_matrix needs 9 values and projection_matrix 12')
    return info


class VideoPublisher(Node):
    """Publishes the frames of a source at its rate (or ``rate``), optionally looping."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('video_publisher', **kwargs)
        self.source_name = declare(
            self,
            'source',
            '0',
            'Camera index or device (/dev/video0), video file, or folder of images.',
            read_only=True,
        )
        self.rate = declare(
            self, 'rate', 0.0, 'Frames per second; 0: the source own rate.', low=0.0, high=1000.0, read_only=True
        )
        self.loop = declare(self, 'loop', False, 'Start a file or folder again at its end.', read_only=True)
        self.wait_for = declare(
            self,
            'wait_for_subscribers',
            0,
            'Hold the first frame until image_raw has this many subscribers (30 s at most).',
            low=0,
            high=100,
            read_only=True,
        )
        self.frame_id = declare(
            self, 'frame_id', 'camera_optical_frame', 'frame_id of the published headers.', read_only=True
        )
        calibration = declare(
            self, 'camera_info_file', '', 'camera_calibration YAML; empty: the default 60° pinhole.', read_only=True
        )
        reliability = declare(
            self, 'qos_reliability', 'reliable', 'reliable (every subscriber matches) or best_effort.', read_only=True
        )
        if reliability not in ('reliable', 'best_effort'):
            raise ValueError(f"qos_reliability must be 'reliable' or 'best_effort', got {reliability!r}")
        self.camera_info = camera_info_from_file(calibration) if calibration else None
        qos = QoSProfile(
            depth=5,
            history=HistoryPolicy.KEEP_LAST,
            reliability=ReliabilityPolicy.RELIABLE if reliability == 'reliable' else ReliabilityPolicy.BEST_EFFORT,
        )
        self.image_pub = self.create_publisher(Image, 'image_raw', qos)
        self.info_pub = self.create_publisher(CameraInfo, 'camera_info', qos)
        self.published = 0
        self.unreadable = 0
        self.state = 'STARTING'
        self.diagnostics_pub = self.create_publisher(DiagnosticArray, '/diagnostics', RESULT_QOS)
        self.create_timer(1.0, self._publish_diagnostics)

    def _publish_diagnostics(self) -> None:
        values = {'source': self.source_name, 'frames_published': self.published, 'frames_unreadable': self.unreadable}
        publish_diagnostics(self, self.diagnostics_pub, [node_status(self, self.state, values)])

    def run(self) -> None:
        """Publish until the source ends (and ``loop`` is off) or rclpy shuts down."""
        # camera_info is optional for the consumers (the cue nodes take none): images decide.
        self.state = 'WAITING_FOR_SUBSCRIBERS'
        deadline = time.monotonic() + 30.0
        while time.monotonic() < deadline and self.image_pub.get_subscription_count() < self.wait_for:
            time.sleep(0.05)
        if self.image_pub.get_subscription_count() < self.wait_for:
            self.get_logger().warn(
                f'publishing although image_raw has {self.image_pub.get_subscription_count()} of '
                f'{self.wait_for} subscribers after 30 s'
            )
        self.state = 'PUBLISHING'
        while rclpy.ok():
            try:
                source = open_frames(self.source_name)
            except FrameSourceError as err:
                raise ValueError(str(err)) from err
            period = 1.0 / (self.rate if self.rate > 0 else source.fps)
            self.get_logger().info(f'publishing {source.name} at {1 / period:.1f} Hz')
            next_due = time.monotonic()
            try:
                for image in source:
                    if not rclpy.ok():
                        return
                    if image is None:
                        self.unreadable += 1
                        self.get_logger().warn(
                            'an image of the source cannot be read: skipped', throttle_duration_sec=5.0
                        )
                        continue
                    delay = next_due - time.monotonic()
                    if delay > 0:
                        time.sleep(delay)
                    next_due += period
                    self.publish(image)
            finally:
                source.close()
            if not self.loop:
                self.state = 'FINISHED'
                return

    def publish(self, image: np.ndarray) -> None:
        """Publish one frame and its camera_info under the same header."""
        msg = array_to_image(image, 'bgr8')
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.header.frame_id = self.frame_id
        height, width = image.shape[:2]
        info = self.camera_info if self.camera_info is not None else default_camera_info(width, height)
        info.header = msg.header
        self.image_pub.publish(msg)
        self.info_pub.publish(info)
        self.published += 1


def _publish_all(nodes: list[Node]) -> None:
    publisher = nodes[0]
    assert isinstance(publisher, VideoPublisher)
    publisher.run()
    for topic in (publisher.image_pub, publisher.info_pub):
        topic.wait_for_all_acked(Duration(seconds=2.0))
    publisher.get_logger().info(f'published {publisher.published} frames, skipped {publisher.unreadable} unreadable')


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run human_tracker video_publisher``; returns the exit code."""
    return run_nodes(lambda: [VideoPublisher()], args, name='video_publisher', run=_publish_all, summary=__doc__)


if __name__ == '__main__':
    sys.exit(main())
