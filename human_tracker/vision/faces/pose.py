"""Where a head faces, from its face's five landmarks: yaw and pitch by solvePnP on a mean face.

The five landmarks a face detector gives (eyes, nose tip, mouth corners) are matched to the
same points of a mean adult face (:data:`MEAN_FACE`, millimetres) by ``cv2.solvePnP``
(SQPnP: the global optimum from as few as three points). The camera is taken as a pinhole far
from the face (a focal length of :data:`FAR_FOCAL` face widths): a face is small against its
distance, so its intrinsics barely change the angles, and the frames need no calibration.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import cv2
import numpy as np

__all__ = ['MEAN_FACE', 'SIDE_YAW', 'HeadOrientation', 'head_orientation', 'view_of']

MEAN_FACE = np.array(
    [
        [-31.5, -33.0, 28.0],  # the person's right eye (on the image's left when facing the camera)
        [31.5, -33.0, 28.0],  # left eye
        [0.0, 0.0, 0.0],  # nose tip: nearest the camera
        [-25.0, 30.0, 22.0],  # right mouth corner
        [25.0, 30.0, 22.0],  # left mouth corner
    ],
    np.float64,
)
"""A mean adult face's landmarks, mm, in the camera's axes when the face looks straight at it
(x to the image's right, y down, z away from the camera), the nose tip at the origin."""

FAR_FOCAL = 20.0
"""The assumed focal length in face widths (eye to eye): the face's depth is small against its distance."""

SIDE_YAW = math.radians(40.0)
"""Turned further than this (either way) a face is seen from the side."""


class HeadOrientation(NamedTuple):
    """Where a face looks, radians, in the camera's view.

    Attributes:
        yaw: Turned toward the image's right (the person's left) is positive; 0 facing the camera.
        pitch: Looking up is positive.
    """

    yaw: float
    pitch: float


def head_orientation(landmarks: tuple[tuple[float, float], ...]) -> HeadOrientation | None:
    """The orientation of the face whose five ``landmarks`` (pixels, in the order of
    :data:`MEAN_FACE`) are given; None without five, or where the pose cannot be solved."""
    if len(landmarks) != 5:
        return None
    points = np.asarray(landmarks, np.float64)
    eyes = float(np.linalg.norm(points[1] - points[0]))
    if eyes < 1.0:
        eyes = float(np.ptp(points[:, 0])) or 1.0
    centre = points.mean(axis=0)
    focal = FAR_FOCAL * eyes
    camera = np.array([[focal, 0.0, centre[0]], [0.0, focal, centre[1]], [0.0, 0.0, 1.0]])
    solved, rotation, _ = cv2.solvePnP(MEAN_FACE, points, camera, None, flags=cv2.SOLVEPNP_SQPNP)
    if not solved:
        return None
    # The face's forward direction (out of the face, toward the camera when it looks at it).
    forward = cv2.Rodrigues(rotation)[0] @ np.array([0.0, 0.0, -1.0])
    yaw = math.atan2(float(forward[0]), float(-forward[2]))
    pitch = math.atan2(float(-forward[1]), math.hypot(float(forward[0]), float(forward[2])))
    return HeadOrientation(yaw, pitch)


def view_of(landmarks: tuple[tuple[float, float], ...]) -> int:
    """0 for a face toward the camera (or landmarks that say nothing), 1 turned to the person's
    left (:data:`SIDE_YAW` or more), 2 to their right."""
    orientation = head_orientation(landmarks)
    if orientation is None or abs(orientation.yaw) < SIDE_YAW:
        return 0
    return 1 if orientation.yaw > 0 else 2
