"""The edge map the contour is fitted to (§2.3): Canny edges labelled with their gradient's orientation."""

from __future__ import annotations

import cv2
import numba
import numpy as np

__all__ = ['edge_map']


def edge_map(
    image: np.ndarray,
    *,
    blur_sigma: float = 1.5,
    low_threshold: float = 40.0,
    high_threshold: float = 100.0,
) -> np.ndarray:
    """Binary edge image the contour is fitted to (Canny on a Gaussian-smoothed image).

    Args:
        image: ``(H, W) uint8`` intensity image, or ``(H, W, 3) uint8`` colour image: then
            each pixel takes the gradient of the channel where it is strongest, so an edge
            between two colours of equal brightness (a hand before a wooden door) counts.
        blur_sigma: Standard deviation of the Gaussian pre-filter, pixels (0: none).
        low_threshold: Canny hysteresis low threshold, gradient units.
        high_threshold: Canny hysteresis high threshold, gradient units.

    Returns:
        ``(H, W) uint8``: 0 off edges; on an edge pixel, 1 + the orientation of the image
        gradient in whole degrees modulo 180 (so 1..180), which the measurement compares
        with the contour normal.
    """
    if blur_sigma > 0:
        image = cv2.GaussianBlur(image, (0, 0), blur_sigma)
    # One 3x3 Sobel pass serves Canny (which would compute the same derivatives itself) and
    # the orientation, computed only where there is an edge.
    dx = cv2.Sobel(image, cv2.CV_16S, 1, 0, ksize=3)
    dy = cv2.Sobel(image, cv2.CV_16S, 0, 1, ksize=3)
    if image.ndim == 3:
        dx, dy = _strongest_channel(dx, dy)
    edges = cv2.Canny(dx, dy, low_threshold, high_threshold)
    out = np.empty(image.shape[:2], dtype=np.uint8)
    _orientation_labels(edges, dx, dy, out)
    return out


@numba.njit(cache=True, nogil=True)
def _orientation_labels(edges: np.ndarray, dx: np.ndarray, dy: np.ndarray, out: np.ndarray) -> None:
    """``out``: 0 off edges, 1 + the gradient orientation in whole degrees modulo 180 on them."""
    height, width = edges.shape
    for v in range(height):
        for u in range(width):
            if edges[v, u] == 0:
                out[v, u] = 0
            else:
                degrees = np.degrees(np.arctan2(np.float32(dy[v, u]), np.float32(dx[v, u])))
                out[v, u] = np.int64(np.rint(degrees)) % 180 + 1


@numba.njit(cache=True, nogil=True)
def _strongest_channel(dx: np.ndarray, dy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel, the derivatives ``(H, W, 3) int16`` of the channel with the largest |dx| + |dy|
    (the first of equals)."""
    height, width = dx.shape[:2]
    flat_x, flat_y = dx.reshape(height * width * 3), dy.reshape(height * width * 3)
    out_x = np.empty(height * width, dtype=np.int16)
    out_y = np.empty(height * width, dtype=np.int16)
    # Selects rather than a branch, on flat arrays and in one thread, so that the compiler
    # vectorises the loop: 0.015 ms on a 320x240 frame, against 0.18 ms for a parallel loop
    # over (pixel, channel) indices.
    for i in range(height * width):
        j = 3 * i
        x0, y0 = np.int32(flat_x[j]), np.int32(flat_y[j])
        x1, y1 = np.int32(flat_x[j + 1]), np.int32(flat_y[j + 1])
        x2, y2 = np.int32(flat_x[j + 2]), np.int32(flat_y[j + 2])
        strength0, strength1, strength2 = abs(x0) + abs(y0), abs(x1) + abs(y1), abs(x2) + abs(y2)
        first = strength1 > strength0
        x = x1 if first else x0
        y = y1 if first else y0
        second = strength2 > (strength1 if first else strength0)
        out_x[i] = x2 if second else x
        out_y[i] = y2 if second else y
    return out_x.reshape(height, width), out_y.reshape(height, width)
