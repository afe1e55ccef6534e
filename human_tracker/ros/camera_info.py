"""A node's camera intrinsics, from ``camera_info``."""

from __future__ import annotations

import numpy as np
from rclpy.node import Node
from sensor_msgs.msg import CameraInfo

from human_tracker.ros.common import RESULT_QOS
from human_tracker.vision.geometry.camera import default_camera_matrix

__all__ = ['CameraInfoInput']

# camera_info's distortion models whose coefficients are OpenCV's (k1, k2, p1, p2, k3, ...).
_OPENCV_DISTORTION_MODELS = ('plumb_bob', 'rational_polynomial')


class CameraInfoInput:
    """The last ``camera_info`` a node received: K, P's intrinsics and the distortion D.

    Attributes:
        camera_matrix: K, None until a usable one arrives.
        rectified_matrix: The intrinsics of P (a rectified image's), or None.
        distortion: D of a model OpenCV undistorts with, or None (none, or a model it does not take).
    """

    def __init__(self, node: Node) -> None:
        """Subscribe ``node`` to ``camera_info``."""
        self.node = node
        self.camera_matrix: np.ndarray | None = None
        self.rectified_matrix: np.ndarray | None = None
        self.distortion: np.ndarray | None = None
        node.create_subscription(CameraInfo, 'camera_info', self._on_camera_info, RESULT_QOS)

    def _on_camera_info(self, msg: CameraInfo) -> None:
        k = np.asarray(msg.k, dtype=np.float64).reshape(3, 3)
        if k[0, 0] > 0 and k[1, 1] > 0:
            self.camera_matrix = k
            self.rectified_matrix = np.asarray(msg.p, dtype=np.float64).reshape(3, 4)[:, :3]
        self.distortion = None
        if np.any(msg.d):
            if msg.distortion_model in _OPENCV_DISTORTION_MODELS:
                self.distortion = np.asarray(msg.d, dtype=np.float64)
            else:
                self.node.get_logger().warn(
                    f'camera_info distortion model {msg.distortion_model!r} is not supported: pixels taken '
                    'as undistorted (feed a rectified image, with image_rectified: true)',
                    throttle_duration_sec=60.0,
                )

    def lens(self, width: int, height: int, rectified: bool) -> tuple[np.ndarray, np.ndarray | None]:
        """K and the distortion coefficients D of ``camera_info`` for a raw image; for a rectified
        one, P's intrinsics and no distortion (ROS's convention); the default K until one arrives."""
        if self.camera_matrix is None:
            return default_camera_matrix(width, height), None
        if rectified:
            usable = self.rectified_matrix is not None and self.rectified_matrix[0, 0] > 0
            return (self.rectified_matrix if usable else self.camera_matrix), None
        return self.camera_matrix, self.distortion

    def intrinsics(self, width: int, height: int) -> np.ndarray:
        """K from ``camera_info``, or the documented default (60° pinhole) until one arrives."""
        return self.lens(width, height, rectified=False)[0]
