"""video_publisher over real DDS: a video file, a folder of frames, a calibration file."""

from __future__ import annotations

import time
from pathlib import Path

import cv2
import numpy as np
import pytest
import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from ros_harness import environment
from sensor_msgs.msg import CameraInfo, Image

from human_tracker.ros.image_conversion import image_to_array
from human_tracker.ros.processes import NodeProcess

CALIBRATION = """image_width: 64
image_height: 48
camera_name: test
camera_matrix: {rows: 3, cols: 3, data: [100.0, 0.0, 32.0, 0.0, 101.0, 24.0, 0.0, 0.0, 1.0]}
distortion_model: plumb_bob
distortion_coefficients: {rows: 1, cols: 5, data: [0.1, 0.0, 0.0, 0.0, 0.0]}
"""


def _frames(count: int) -> list[np.ndarray]:
    return [np.full((48, 64, 3), 20 * i, dtype=np.uint8) for i in range(count)]


def _collect(tmp_path: Path, params: list[str], expected: int) -> tuple[list[Image], list[CameraInfo], NodeProcess]:
    # Like a replay into a pipeline: hold the first frame until this test subscribes.
    args = ['--ros-args', '-p', 'wait_for_subscribers:=1', *params]
    publisher = NodeProcess('human_tracker.ros.video_publisher', args, environment(), tmp_path / 'log')
    rclpy.init()
    node = Node('video_test')
    images: list[Image] = []
    infos: list[CameraInfo] = []
    qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
    node.create_subscription(Image, 'image_raw', images.append, qos)
    node.create_subscription(CameraInfo, 'camera_info', infos.append, qos)
    try:
        publisher.start()
        deadline = time.monotonic() + 30.0
        while len(images) < expected and time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.05)
        while len(infos) < len(images) and time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.05)
        publisher.wait(20.0)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        publisher.stop()
    return images, infos, publisher


def test_folder_of_frames_with_calibration(tmp_path) -> None:
    folder = tmp_path / 'frames'
    folder.mkdir()
    for i, frame in enumerate(_frames(5)):
        cv2.imwrite(str(folder / f'{i:04d}.png'), frame)
    (tmp_path / 'camera.yaml').write_text(CALIBRATION)
    params = ['-p', f'source:={folder}', '-p', 'rate:=50.0', '-p', f'camera_info_file:={tmp_path / "camera.yaml"}']
    images, infos, publisher = _collect(tmp_path, params, 5)
    assert publisher.process.returncode == 0, publisher.output()
    assert 'published 5 frames' in publisher.output()
    assert len(images) == len(infos) == 5
    for image, info in zip(images, infos, strict=True):
        assert image.header == info.header and image.header.frame_id == 'camera_optical_frame'
        assert image.encoding == 'bgr8' and (image.width, image.height) == (64, 48)
    assert infos[0].k.tolist() == [100.0, 0.0, 32.0, 0.0, 101.0, 24.0, 0.0, 0.0, 1.0]
    assert infos[0].d.tolist() == pytest.approx([0.1, 0, 0, 0, 0])
    assert image_to_array(images[-1])[0, 0].tolist() == [80, 80, 80]  # the last frame, 20 * 4


def test_video_file_with_the_default_camera(tmp_path) -> None:
    path = tmp_path / 'clip.avi'
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*'MJPG'), 25.0, (64, 48))
    for frame in _frames(8):
        writer.write(frame)
    writer.release()
    images, infos, publisher = _collect(tmp_path, ['-p', f'source:={path}', '-p', 'rate:=50.0'], 8)
    assert publisher.process.returncode == 0, publisher.output()
    assert 'published 8 frames' in publisher.output()
    assert len(images) == len(infos) == 8
    assert infos[0].k[0] == pytest.approx(32 / np.tan(np.radians(30)))  # 60° field of view


def test_missing_source_is_refused_with_a_reason(tmp_path) -> None:
    publisher = NodeProcess(
        'human_tracker.ros.video_publisher',
        ['--ros-args', '-p', f'source:={tmp_path / "none.mp4"}'],
        environment(),
        tmp_path / 'log',
    )
    assert publisher.start().wait(30.0) == 2
    assert 'neither a camera device, a video file nor a folder' in publisher.output()
