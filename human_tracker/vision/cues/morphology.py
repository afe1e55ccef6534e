"""Structuring elements shared by the mask-cleaning stages (background, flow, tracker)."""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ['disk']


def disk(radius: int) -> np.ndarray:
    """``(2r + 1, 2r + 1) uint8`` elliptic structuring element of ``radius`` pixels."""
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1, 2 * radius + 1))
