"""Phase 1 of §3.2: the regions skin may be in: candidate cells merged by adjacency, or seed
pixels grown by hysteresis."""

from __future__ import annotations

import cv2
import numba
import numpy as np

from human_tracker.vision.cues.skin.model import SkinModel, ohta


def candidate_cells(chroma: np.ndarray, model: SkinModel, match_scale: float = 1.0) -> np.ndarray:
    """Phase 1a: cells whose mean (I2, I3) lies within the skin classes.

    Args:
        chroma: ``(R, C, 2)`` the cells' mean (I2, I3) (:func:`cell_chroma`).
        model: The skin classes.
        match_scale: Multiplies ``model.match_distance``.

    Returns:
        ``(R, C) bool``, True for candidate skin cells.
    """
    return model.distance(chroma) <= model.match_distance * match_scale


def cell_chroma(image: np.ndarray, cell_size: int) -> np.ndarray:
    """``(H // cell_size, W // cell_size, 2)`` mean (I2, I3) of each ``cell_size`` square cell
    of a BGR image (phase 1's partition); a partial last row / column of cells is ignored."""
    rows, cols = image.shape[0] // cell_size, image.shape[1] // cell_size
    if rows == 0 or cols == 0:
        return np.zeros((rows, cols, 2), dtype=np.float32)
    cropped = np.asarray(image[: rows * cell_size, : cols * cell_size], dtype=np.float32)
    # I1 I2 I3 are linear in B, G, R, so the cell's mean chromaticity is that of its mean
    # colour; area interpolation by a whole factor is the mean of each cell.
    means = cv2.resize(cropped, (cols, rows), interpolation=cv2.INTER_AREA).reshape(rows, cols, 3)
    return ohta(means)[..., 1:]


def hysteresis_regions(
    image: np.ndarray, model: SkinModel, seed_scale: float = 1.0, grow_scale: float = 2.5
) -> tuple[np.ndarray, int]:
    """Phase 1 with ``regions: pixels``: skin regions grown from seed pixels.

    Args:
        image: ``(H, W, 3) uint8`` BGR image.
        model: The skin classes.
        seed_scale: A pixel within ``seed_scale * model.match_distance`` of a class is a seed.
        grow_scale: A region takes the 8-connected pixels within ``grow_scale *
            model.match_distance`` of a class around its seeds.

    Returns:
        ``(H, W) int32`` labels (0: no region, 1..n: regions) and n.
    """
    levels = _distance_levels(
        np.ascontiguousarray(image, dtype=np.uint8),
        model.distance_table,
        seed_scale * model.match_distance,
        grow_scale * model.match_distance,
    )
    count, labels = cv2.connectedComponents((levels > 0).view(np.uint8), connectivity=8)
    seeded = np.zeros(count, dtype=bool)
    seeded[labels[levels == 2]] = True
    seeded[0] = False
    relabel = np.zeros(count, dtype=np.int32)
    relabel[seeded] = np.arange(1, np.count_nonzero(seeded) + 1, dtype=np.int32)
    return relabel[labels], int(np.count_nonzero(seeded))


@numba.njit(cache=True, nogil=True)
def _distance_levels(image: np.ndarray, table: np.ndarray, seed: float, grow: float) -> np.ndarray:
    """Per pixel: 2 within ``seed`` of a class, 1 within ``grow``, 0 beyond (``table``: distances)."""
    height, width = image.shape[:2]
    levels = np.zeros((height, width), dtype=np.uint8)
    for v in range(height):
        for u in range(width):
            b, g, r = int(image[v, u, 0]), int(image[v, u, 1]), int(image[v, u, 2])
            d = table[r - b + 255, 2 * g - r - b + 510]
            if d <= seed:
                levels[v, u] = 2
            elif d <= grow:
                levels[v, u] = 1
    return levels


def merge_cells(
    candidates: np.ndarray, min_region_cells: int = 1, chroma: np.ndarray | None = None, max_distance: float = 0.0
) -> tuple[np.ndarray, int]:
    """Phase 1b: merge adjacent candidate cells (8-connected) into regions.

    Args:
        candidates: ``(R, C) bool`` candidate cells.
        min_region_cells: Regions with fewer cells are dropped.
        chroma: ``(R, C, 2)`` the cells' mean (I2, I3) (:func:`cell_chroma`), with ``max_distance``.
        max_distance: > 0: two adjacent cells join only when their ``chroma`` lie within it.

    Returns:
        ``(R, C) int32`` labels (0: no region, 1..n: regions) and n.
    """
    if max_distance > 0 and chroma is not None:
        labels = _similar_components(candidates, np.asarray(chroma, dtype=np.float64), max_distance**2)
        count = int(labels.max(initial=0)) + 1
    else:
        count, labels = cv2.connectedComponents(candidates.astype(np.uint8), connectivity=8)
    sizes = np.bincount(labels.ravel(), minlength=count)
    keep = sizes >= min_region_cells
    keep[0] = False
    relabel = np.zeros(count, dtype=np.int32)
    relabel[keep] = np.arange(1, np.count_nonzero(keep) + 1, dtype=np.int32)
    return relabel[labels], int(np.count_nonzero(keep))


@numba.njit(cache=True, nogil=True)
def _root(parent: np.ndarray, i: int) -> int:
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@numba.njit(cache=True, nogil=True)
def _similar_components(candidates: np.ndarray, chroma: np.ndarray, max_squared: float) -> np.ndarray:
    """``(R, C) int32`` labels (0 outside, 1..n) of the 8-connected candidate cells, two
    neighbours joined only when their chroma lie within ``sqrt(max_squared)`` (union-find)."""
    rows, cols = candidates.shape
    parent = np.arange(rows * cols)
    for v in range(rows):
        for u in range(cols):
            if not candidates[v, u]:
                continue
            # Each pair once: the right neighbour and the three below.
            for dv, du in ((0, 1), (1, -1), (1, 0), (1, 1)):
                y, x = v + dv, u + du
                if y < rows and 0 <= x < cols and candidates[y, x]:
                    d2 = (chroma[v, u, 0] - chroma[y, x, 0]) ** 2 + (chroma[v, u, 1] - chroma[y, x, 1]) ** 2
                    if d2 <= max_squared:
                        a, b = _root(parent, v * cols + u), _root(parent, y * cols + x)
                        parent[max(a, b)] = min(a, b)
    labels = np.zeros((rows, cols), np.int32)
    names = np.zeros(rows * cols, np.int32)
    count = 0
    for v in range(rows):
        for u in range(cols):
            if candidates[v, u]:
                r = _root(parent, v * cols + u)
                if names[r] == 0:
                    count += 1
                    names[r] = count
                labels[v, u] = names[r]
    return labels
