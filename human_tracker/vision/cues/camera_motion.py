"""The camera's own image motion between two frames, and moving states and images with it.

The paper's cues assume a fixed camera, or (§2.4.2) a known rotation. A robot's head turns
and a hand-held camera sways: the whole scene then shifts between frames, the background
model marks every edge as moving, and the particles' dynamics, which extrapolate the
target's image motion, are thrown by the camera's. This module estimates that motion from
the frames themselves: corners (Shi-Tomasi) of the previous frame followed into the current
one by pyramidal Lucas-Kanade, and a similarity (shift, rotation, zoom) fitted to them by
RANSAC, so that the target and other moving things count as outliers. The cues are then
compensated: the particles and the background model are carried with the scene.

A transform is a ``(2, 3)`` matrix ``[[a, -b, tx], [b, a, ty]]`` taking a pixel of the previous
frame to where that scene point is in the current one.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

__all__ = [
    'CameraMotion',
    'CameraMotionParameters',
    'CameraShake',
    'estimate_camera_motion',
    'scale_transform',
]


@dataclass(frozen=True)
class CameraMotionParameters:
    """Constants of the camera-motion estimate.

    Attributes:
        max_features: Corners followed from one frame to the next.
        feature_quality: Shi-Tomasi quality level of a corner, relative to the best one.
        feature_spacing: Smallest distance between corners, pixels.
        ransac_threshold: Reprojection error, pixels, under which a corner fits the similarity.
        min_inliers: Corners that must fit for the estimate to count.
        min_motion: Largest displacement, pixels, that any image corner undergoes below
            which the camera counts as still (the identity is returned: on a fixed camera
            nothing changes).
        kept_share: :class:`CameraMotion` follows the corners that fitted the last frame
            while at least this share of ``max_features`` did, else detects new ones.
    """

    max_features: int = 100
    feature_quality: float = 0.01
    feature_spacing: float = 8.0
    ransac_threshold: float = 1.0
    min_inliers: int = 20
    min_motion: float = 1.0
    kept_share: float = 0.85


def estimate_camera_motion(
    previous: np.ndarray,
    current: np.ndarray,
    exclude: np.ndarray | None = None,
    parameters: CameraMotionParameters = CameraMotionParameters(),
) -> np.ndarray | None:
    """The similarity taking ``previous`` to ``current``.

    Args:
        previous: ``(H, W) uint8`` grey-level frame.
        current: ``(H, W) uint8`` grey-level frame of the same size.
        exclude: Optional ``(H, W) uint8`` mask, non-zero where corners are not taken (the
            tracked target, which moves on its own).
        parameters: See :class:`CameraMotionParameters`.

    Returns:
        ``(2, 3) float64`` transform; the identity when the motion is below ``min_motion``;
        None when too few corners could be followed or fitted (a blank or blurred frame).
    """
    return _follow(previous, current, _corners(previous, exclude, parameters), parameters)[0]


@dataclass
class CameraMotion:
    """:func:`estimate_camera_motion` over a stream of frames, following the same corners.

    The corners that fitted the last frame's similarity are followed into the next frame
    while ``kept_share`` of ``max_features`` are left, else new ones are detected: the corner
    detection takes a third of the estimate's time. On a fixed camera nearly every corner
    fits and is kept; on a swaying hand-held one, corners kept at 50 % or 70 % bunched where
    the image stays sharp and the fit lost the scene (sunshade, precision at 20 px 0.94 ->
    0.85), so there they are detected afresh on most frames. Corners on ``exclude`` are dropped.
    """

    parameters: CameraMotionParameters = field(default_factory=CameraMotionParameters)
    corners: np.ndarray | None = None

    def reset(self) -> None:
        """Forget the corners (a new stream, or a frame of another size)."""
        self.corners = None

    def estimate(
        self, previous: np.ndarray, current: np.ndarray, exclude: np.ndarray | None = None
    ) -> np.ndarray | None:
        """As :func:`estimate_camera_motion`, from the corners kept from the last call."""
        corners = self.corners
        if corners is not None and exclude is not None and exclude.shape == previous.shape:
            u = np.clip(corners[:, 0, 0].astype(np.int64), 0, previous.shape[1] - 1)
            v = np.clip(corners[:, 0, 1].astype(np.int64), 0, previous.shape[0] - 1)
            corners = corners[exclude[v, u] == 0]
        if corners is None or len(corners) < self.parameters.kept_share * self.parameters.max_features:
            corners = _corners(previous, exclude, self.parameters)
        transform, self.corners = _follow(previous, current, corners, self.parameters)
        return transform


def _corners(previous: np.ndarray, exclude: np.ndarray | None, p: CameraMotionParameters) -> np.ndarray | None:
    """Shi-Tomasi corners ``(N, 1, 2) float32`` of ``previous`` away from ``exclude``."""
    mask = None if exclude is None else np.where(exclude > 0, 0, 255).astype(np.uint8)
    return cv2.goodFeaturesToTrack(previous, p.max_features, p.feature_quality, p.feature_spacing, mask=mask)


def _follow(
    previous: np.ndarray, current: np.ndarray, corners: np.ndarray | None, p: CameraMotionParameters
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The similarity fitted to ``corners`` followed from ``previous`` into ``current``, and
    where the corners that fit it are in ``current`` (None when there is no fit)."""
    if previous.shape != current.shape:
        raise ValueError(f'frames differ in size: {previous.shape} and {current.shape}')
    if corners is None or len(corners) < p.min_inliers:
        return None, None
    # On the frames as given, not reduced further: reduced by 2 (twice as fast), the dark,
    # noisy start of david_colour gave motions where these give none (precision 0.97 -> 0.64).
    followed, status, _ = cv2.calcOpticalFlowPyrLK(previous, current, corners, None, winSize=(15, 15), maxLevel=2)
    found = status.ravel() == 1
    if int(found.sum()) < p.min_inliers:
        return None, None
    source, target = corners[found].reshape(-1, 2), followed[found].reshape(-1, 2)
    transform, inliers = cv2.estimateAffinePartial2D(
        source, target, method=cv2.RANSAC, ransacReprojThreshold=p.ransac_threshold
    )
    if transform is None or int(inliers.sum()) < p.min_inliers:
        return None, None
    kept = target[inliers.ravel() == 1].reshape(-1, 1, 2)
    height, width = previous.shape
    frame_corners = np.array([[0, 0, 1], [width, 0, 1], [0, height, 1], [width, height, 1]], dtype=np.float64)
    displacement = frame_corners @ transform.T - frame_corners[:, :2]
    if np.max(np.hypot(displacement[:, 0], displacement[:, 1])) < p.min_motion:
        return np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]), kept
    return transform.astype(np.float64), kept


def scale_transform(transform: np.ndarray, factor: float) -> np.ndarray:
    """The same camera motion in pixels ``factor`` times as large (``(2, 3)``: the shift scales,
    the rotation and zoom do not): a motion measured on a reduced frame, in the camera's pixels."""
    scaled = np.array(transform, dtype=np.float64, copy=True)
    scaled[:, 2] *= factor
    return scaled


@dataclass
class CameraShake:
    """A track's view of the camera's motion: the shake its particles are carried with.

    The running mean of the camera's shift per frame (a pan, ``pan_smoothing``: an operator or
    a robot's head following the person, who then stays put in the image) is left to the AR(2)
    velocity; only the rest, the shake, carries the particles.

    Attributes:
        pan: ``(2,)`` the running mean shift, working pixels per frame.
        previous: The grey working frame before (the estimate's), None at first.
        motion: The shake carried onto the last frame (``(2, 3)``, working pixels), None: none.
    """

    pan: np.ndarray = field(default_factory=lambda: np.zeros(2))
    previous: np.ndarray | None = field(default=None, repr=False)
    motion: np.ndarray | None = None

    def follow(
        self,
        grey: np.ndarray,
        given: np.ndarray | None,
        scale: float,
        particles: np.ndarray | None,
        *,
        estimate: bool,
        pan_smoothing: float,
    ) -> np.ndarray | None:
        """The shake onto the frame ``grey`` (working pixels) to carry ``particles`` (working
        pixels) with, or None: ``given`` (camera pixels, ``scale`` working pixels per camera
        pixel), or with ``estimate`` estimated here away from the target around the particles."""
        previous, self.previous = self.previous, grey
        self.motion = None
        if given is not None:
            transform = scale_transform(given, scale)
        elif estimate and particles is not None and previous is not None and previous.shape == grey.shape:
            x, y, s = particles.mean(axis=0)[:3]
            exclude = np.zeros(grey.shape, np.uint8)
            # The head and shoulders (or the hand and forearm) around the state: it moves on its own.
            cv2.rectangle(exclude, (int(x - 1.5 * s), int(y - 1.5 * s)), (int(x + 1.5 * s), int(y + 2.5 * s)), 255, -1)
            transform = estimate_camera_motion(previous, grey, exclude)
        else:
            return None
        if transform is None:
            return None
        # The pan is followed while the filter waits too: a target found mid-pan is not shaken.
        self.pan = pan_smoothing * self.pan + (1.0 - pan_smoothing) * transform[:, 2]
        transform[:, 2] -= self.pan
        if particles is None or np.array_equal(transform, np.eye(2, 3)):
            return None
        self.motion = transform
        return transform
