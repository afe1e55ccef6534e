"""The working resolution: every cue is computed on the frame reduced to a working width.

Each stage's cost grows with the pixel count, while the method needs a head or a hand only
some tens of pixels wide: at 320 pixels across, a head at robot range still spans 30-80
pixels. Frames wider than the working width are reduced by area averaging (which also
smooths the sensor noise); narrower frames are used as they are. Parameters in pixels keep
their meaning in the camera's pixels: the tracker scales them by the same factor and reports
poses in the camera's pixels.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ['same_frame', 'working_scale', 'working_shape', 'to_working']


def working_scale(width: int, working_width: int) -> float:
    """Working pixels per camera pixel for frames ``width`` pixels wide, in (0, 1].

    Args:
        width: Frame width, pixels.
        working_width: Width frames are reduced to; 0 keeps every frame at full size.
    """
    if working_width <= 0 or width <= working_width:
        return 1.0
    return working_width / width


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
