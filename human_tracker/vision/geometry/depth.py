"""The target's distance from a depth image registered to the colour image (RGB-D cameras).

Depth cameras leave holes (no reading: 0 or NaN) at edges, on hair and on dark or shiny
surfaces, and a box around a head also holds the wall behind it. The distance is therefore
the median of the valid readings in the middle of the target's region, and its uncertainty
their robust spread (1.4826 times the median absolute deviation: the standard deviation for
Gaussian noise, unmoved by the background pixels that remain).
"""

from __future__ import annotations

import numpy as np

__all__ = ['CORE_SHARE', 'MIN_READINGS', 'depth_image_to_metres', 'region_depth']

CORE_SHARE = 0.5
"""Share of the region's width and height, around its centre, whose readings count."""

MIN_READINGS = 20
"""Fewer valid readings than this in the core give no depth (the scale's is used)."""


def depth_image_to_metres(depth: np.ndarray) -> np.ndarray:
    """``(H, W)`` float32 metres from a ``16UC1`` (millimetres) or ``32FC1`` (metres) depth
    image; holes (0, NaN, inf) become NaN."""
    metres = depth.astype(np.float32) / np.float32(1000.0) if depth.dtype == np.uint16 else depth.astype(np.float32)
    metres[~np.isfinite(metres) | (metres <= 0)] = np.nan
    return metres


def region_depth(
    depth: np.ndarray, box: tuple[float, float, float, float], image_shape: tuple[int, int]
) -> tuple[float, float] | None:
    """Distance (metres) of the target in ``box`` and its spread, or None without enough readings.

    Args:
        depth: ``(h, w)`` float metres, NaN where there is no reading (:func:`depth_image_to_metres`),
            registered to the colour image at any resolution of it.
        box: ``(x, y, w, h)`` the target's region in the colour image's pixels.
        image_shape: ``(H, W)`` of the colour image.

    Returns:
        ``(median, spread)`` in metres, spread = 1.4826 MAD of the readings in the region's core
        (``CORE_SHARE`` of its width and height).
    """
    factor_y, factor_x = depth.shape[0] / image_shape[0], depth.shape[1] / image_shape[1]
    x, y, w, h = box
    margin_x, margin_y = 0.5 * (1.0 - CORE_SHARE) * w, 0.5 * (1.0 - CORE_SHARE) * h
    left, right = int(max(0, (x + margin_x) * factor_x)), int(min(depth.shape[1], (x + w - margin_x) * factor_x))
    top, bottom = int(max(0, (y + margin_y) * factor_y)), int(min(depth.shape[0], (y + h - margin_y) * factor_y))
    readings = depth[top:bottom, left:right]
    readings = readings[np.isfinite(readings)]
    if readings.size < MIN_READINGS:
        return None
    median = float(np.median(readings))
    return median, 1.4826 * float(np.median(np.abs(readings - median)))
