"""The working resolution: every cue is computed on the frame reduced to a working width.

Each stage's cost grows with the pixel count, while the method needs a head or a hand only
some tens of pixels wide: at 320 pixels across, a head at robot range still spans 30-80
pixels. Frames wider than the working width are reduced by area averaging (which also
smooths the sensor noise); narrower frames are used as they are. Parameters in pixels keep
their meaning in the camera's pixels: the tracker scales them by the same factor and reports
poses in the camera's pixels.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

__all__ = [
    'RESOLUTION_MARGIN',
    'finest_scale',
    'same_frame',
    'to_working',
    'track_width',
    'working_scale',
    'working_shape',
]

RESOLUTION_MARGIN = 1.25
"""A finer working frame is taken with this margin over the one a small target needs."""


def working_scale(width: int, working_width: int) -> float:
    """Working pixels per camera pixel for frames ``width`` pixels wide, in (0, 1].

    Args:
        width: Frame width, pixels.
        working_width: Width frames are reduced to; 0 keeps every frame at full size.
    """
    if working_width <= 0 or width <= working_width:
        return 1.0
    return working_width / width


def track_width(frame_width: int, working_width: int, finest: float | None) -> int:
    """The width a track reduces frames ``frame_width`` pixels wide to (0: none):
    ``working_width``, or wider when the track needs ``finest`` working pixels per camera pixel
    or more (:func:`finest_scale`)."""
    if working_width <= 0 or finest is None or working_scale(frame_width, working_width) >= finest:
        return working_width
    needed = math.ceil(finest * frame_width)
    return 0 if needed >= frame_width else needed


def finest_scale(target_width: float, scale: float, min_target_width: float) -> float | None:
    """The working pixels per camera pixel that keep a target ``target_width`` camera pixels wide
    at least ``min_target_width`` working pixels across, with :data:`RESOLUTION_MARGIN`, when
    ``scale`` does not (else None). A track keeps the finer frame until its target is forgotten:
    going back and forth loses the camera's motion, the detector's run and the colours at each
    change."""
    if min_target_width > 0 and target_width > 0 and min_target_width / target_width > scale:
        return RESOLUTION_MARGIN * min_target_width / target_width
    return None


def working_shape(shape: tuple[int, ...], working_width: int) -> tuple[int, int]:
    """``(H, W)`` of a frame of ``shape`` at the working resolution."""
    scale = working_scale(shape[1], working_width)
    if scale == 1.0:
        return shape[0], shape[1]
    return max(1, round(shape[0] * scale)), max(1, round(shape[1] * scale))


def same_frame(shape: tuple[int, ...], frame_shape: tuple[int, ...]) -> bool:
    """Whether an image of ``shape`` can be ``frame_shape``'s frame at another resolution.

    Its width and height must scale by the same factor, to within one pixel of rounding.
    """
    height, width = shape[:2]
    frame_height, frame_width = frame_shape[:2]
    return height > 0 and width > 0 and abs(width * frame_height / frame_width - height) <= 1.0


def to_working(image: np.ndarray, working_width: int, *, mask: bool = False) -> np.ndarray:
    """``image`` ``(H, W[, C])`` at the working resolution (itself when already that narrow).

    Args:
        image: Frame or mask.
        working_width: See :func:`working_scale`.
        mask: Reduce by nearest neighbour, so that a label image keeps its labels.
    """
    height, width = working_shape(image.shape, working_width)
    if (height, width) == image.shape[:2]:
        return image
    if image.dtype == bool:
        # OpenCV before 5 (a robot's 4.6) refuses boolean arrays: resize their bytes.
        return cv2.resize(image.view(np.uint8), (width, height), interpolation=cv2.INTER_NEAREST).view(bool)
    interpolation = cv2.INTER_NEAREST if mask else cv2.INTER_AREA
    return cv2.resize(image, (width, height), interpolation=interpolation)
