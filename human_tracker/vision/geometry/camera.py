"""Pinhole camera: the target's metric position from its image position and scale.

With intrinsics K (fx, fy, cx, cy, pixels) and the reference region's physical width W
(metres), a state whose reference region is ``w = s * template_width`` pixels wide lies at
depth ``Z = fx W / w``; its centre pixel (u, v) back-projects to
``X = (u - cx) Z / fx``, ``Y = (v - cy) Z / fy`` in the optical frame (x right, y down,
z forward). A lens with distortion D (camera_info's plumb_bob or rational_polynomial model,
OpenCV's coefficients) bends pixels first: the centre pixel is undistorted before it becomes
a ray; the depth from the width is left as measured (the width spans the region's middle,
where the distortion changes little).
"""

from __future__ import annotations

import cv2
import numpy as np

from human_tracker.vision.filter.templates import ContourTemplate, reference_centres

__all__ = [
    'DEFAULT_HORIZONTAL_FOV',
    'FIT_RESIDUAL_GAIN',
    'WIDTH_SPREAD',
    'back_project',
    'default_camera_matrix',
    'metric_positions',
    'position_covariance',
    'undistort_pixels',
]

DEFAULT_HORIZONTAL_FOV = np.deg2rad(60.0)
"""Field of view assumed when no camera_info arrives: 60°, typical of a robot's RGB camera."""


FIT_RESIDUAL_GAIN = 1.0
"""The contour's own error in the pose covariance, in its position errors (see
:func:`position_covariance`); the normalised estimation error it gives on the bags and the
real heads is in docs/evaluation.md."""


WIDTH_SPREAD = 0.05
"""Relative standard deviation of a person's true head or hand width about the assumed
``target_width``: adults' head breadths spread by about 4-5 %. A distance from the width is
off by as much, however well the contour fits."""


def default_camera_matrix(width: int, height: int, horizontal_fov: float = DEFAULT_HORIZONTAL_FOV) -> np.ndarray:
    """``(3, 3)`` K of an ideal pinhole camera with square pixels and the centre mid-image."""
    focal = width / (2.0 * np.tan(horizontal_fov / 2.0))
    return np.array([[focal, 0.0, (width - 1) / 2.0], [0.0, focal, (height - 1) / 2.0], [0.0, 0.0, 1.0]])


def metric_positions(
    states: np.ndarray,
    template: ContourTemplate,
    camera_matrix: np.ndarray,
    target_width: float,
    distortion: np.ndarray | None = None,
    depth: float | None = None,
) -> np.ndarray:
    """Optical-frame positions (metres) of the reference-region centres of ``states``.

    Args:
        states: ``(P, 4)`` or ``(4,)`` states [x, y, s, θ].
        template: The template (its reference box sets what ``target_width`` measures).
        camera_matrix: ``(3, 3)`` intrinsics K.
        target_width: Physical width of the reference region (head or hand), metres.
        distortion: The lens's distortion coefficients D (None: none, or a rectified image).
        depth: The target's measured distance Z (metres, e.g. from a depth image), used instead
            of the one from its width.

    Returns:
        ``(P, 3)`` or ``(3,)`` positions X, Y, Z in metres.
    """
    states = np.asarray(states, dtype=np.float64)
    single = states.ndim == 1
    states = np.atleast_2d(states)
    if depth is None:
        reference_width = template.reference_box[2]
        depth = camera_matrix[0, 0] * target_width / np.maximum(states[:, 2] * reference_width, 1e-6)
    pixels = undistort_pixels(reference_centres(states, template), camera_matrix, distortion)
    positions = back_project(pixels, depth, camera_matrix)
    return positions[0] if single else positions


def back_project(pixels: np.ndarray, depth: float | np.ndarray, camera_matrix: np.ndarray) -> np.ndarray:
    """Optical-frame points (metres) of ``pixels`` ``(N, 2)`` (u, v) at ``depth`` Z (metres, scalar or ``(N,)``).

    Returns:
        ``(N, 3)`` X = (u - cx) Z / fx, Y = (v - cy) Z / fy, Z.
    """
    pixels = np.asarray(pixels, dtype=np.float64)
    depth = np.broadcast_to(np.asarray(depth, dtype=np.float64), pixels.shape[:1])
    fx, fy = camera_matrix[0, 0], camera_matrix[1, 1]
    cx, cy = camera_matrix[0, 2], camera_matrix[1, 2]
    return np.stack([(pixels[:, 0] - cx) * depth / fx, (pixels[:, 1] - cy) * depth / fy, depth], axis=1)


def undistort_pixels(pixels: np.ndarray, camera_matrix: np.ndarray, distortion: np.ndarray | None) -> np.ndarray:
    """``pixels`` ``(N, 2)`` (u, v) of a lens with distortion coefficients ``distortion`` (OpenCV's
    order: k1, k2, p1, p2[, k3[, k4, k5, k6]]) where an ideal pinhole camera with the same K
    would see them; unchanged without distortion (None or all zeros)."""
    pixels = np.asarray(pixels, dtype=np.float64)
    if distortion is None or not np.any(distortion) or len(pixels) == 0:
        return pixels
    coefficients = np.asarray(distortion, dtype=np.float64).reshape(-1, 1)
    ideal = cv2.undistortPoints(pixels.reshape(-1, 1, 2), camera_matrix, coefficients, P=camera_matrix)
    return ideal.reshape(-1, 2)


def position_covariance(
    cloud: np.ndarray,
    position: np.ndarray,
    fit_share: float,
    target_width: float,
    depth_spread: float | None = None,
) -> np.ndarray:
    """``(3, 3)`` covariance (m²) of a pose at ``position`` (metres, optical frame).

    The particle cloud's spread (``cloud``, ``(P, 3)`` metric positions) says how far the
    filter's hypotheses disagree, not how far the best contour sits from the person: after
    resampling the cloud is a few pixels wide. The contour's own error is added: across the
    optical axis ``fit_share`` of ``target_width`` (metres), where ``fit_share`` is the
    contour's position error
    (:attr:`~human_tracker.vision.filter.contour_filter.TrackEstimate.position_error`) in target widths,
    times :data:`FIT_RESIDUAL_GAIN` or the node's gain: a contour on sharp edges of the person
    is placed to about a pixel, one among clutter or on a blurred outline is off by about its
    distance to the edges it found. Along the ray through the pose, for a depth from the
    width, the same share of the depth and :data:`WIDTH_SPREAD` of it (the person's own width),
    or, for a depth measured in a depth image, the readings' ``depth_spread`` (metres).
    """
    lateral = fit_share * target_width
    depth = float(position[2])
    along = depth * np.hypot(fit_share, WIDTH_SPREAD) if depth_spread is None else depth_spread
    # A distance that is off moves the point along its ray, not along the optical axis alone.
    ray = np.asarray(position, dtype=np.float64) / depth
    return np.cov(np.asarray(cloud).T) + np.diag([lateral**2, lateral**2, 0.0]) + along**2 * np.outer(ray, ray)
