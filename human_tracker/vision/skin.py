"""Skin colour segmentation of §3.2 in Ohta's I1 I2 I3 colour space.

The segmentation has the paper's two phases:

1. **Regions.** ``regions: cells`` (the paper's): the image is divided into square cells;
   a cell whose mean chromaticity (I2, I3) falls inside one of the learnt skin classes is a
   candidate, and candidate cells are merged into regions through their adjacency graph
   (8-connected cells). ``regions: pixels`` (a departure, opt-in): each pixel's own (I2, I3)
   is compared with the classes; pixels well inside a class are seeds, and a region is the
   8-connected set of pixels within a wider distance of a class that holds a seed
   (hysteresis, as Canny's), labelled skin as a whole. A face or hand 20-40 pixels across
   fills few whole cells, and a cell on a hand's border mixes skin with background: the
   pixels find 5 of the 6 small faces of ``vtest`` (cells: 1) and 91 % of HGR's skin pixels
   (cells: 79 %), but they also take in skin-coloured wood and clothes that phase 2 sets
   aside, so the tracker keeps the paper's cells (on ``hand2`` the pixels' labels cost
   0.40 -> 0.13).
2. **Local clustering.** In each region, grown by one cell so that its border pixels are
   looked at too, the principal peaks of the I1, I2 and I3 histograms and the valleys that
   bound them define modes; a pixel's cluster is its region and the modes its I1, I2, I3
   fall in. A cluster is labelled skin when the mean and the variance of its (I2, I3) match
   a learnt skin class. A departure (``split_mixed``): a cluster refused is split in two
   by 2-means in (I2, I3) and each part judged alone, so that skin beside clothes of a
   near colour, which the histograms do not separate, is labelled too
   (:data:`MIXED_SKIN`, apart from the paper's :data:`SKIN`).

The skin classes are Gaussian clusters in the (I2, I3) plane learnt from labelled samples
(:func:`train_skin_model`, the ``human_tracker train-skin`` command) and shipped with the
package (:func:`default_skin_model`). :class:`SkinSegmenter` can adapt them online from
the tracked region, within a bounded distance of what was learnt.
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path

import cv2
import numba
import numpy as np

from human_tracker.vision.exposure import MAX_EXPOSURE_GAIN, normalise_exposure

__all__ = [
    'MIXED_SKIN',
    'REGION_METHODS',
    'SKIN',
    'SkinClass',
    'SkinModel',
    'SkinParameters',
    'SkinSegmenter',
    'candidate_cells',
    'cell_chroma',
    'hysteresis_regions',
    'default_skin_model',
    'has_colour',
    'histogram_modes',
    'merge_cells',
    'ohta',
    'segment_skin',
    'train_skin_model',
]

# The labels of :func:`segment_skin`: a cluster the skin classes accept (§3.2), and a part of a
# mixed cluster they accept (``SkinParameters.split_mixed``). Non-zero is skin either way.
SKIN = 255
MIXED_SKIN = 128
# 2-means iterations of a mixed cluster's split.
MIXED_ITERATIONS = 5

_OHTA = np.array([[1 / 3, 1 / 3, 1 / 3], [-1 / 2, 0.0, 1 / 2], [-1 / 4, 1 / 2, -1 / 4]], dtype=np.float32)


def ohta(image: np.ndarray) -> np.ndarray:
    """Ohta's I1 I2 I3 components of a BGR image.

    I1 = (R + G + B) / 3 (intensity), I2 = (R - B) / 2, I3 = (2G - R - B) / 4 (chromaticity).

    Args:
        image: ``(..., 3) uint8`` (or float) pixels in B, G, R order.

    Returns:
        ``(..., 3) float32``: I1 in [0, 255], I2 and I3 in [-127.5, 127.5].
    """
    bgr = np.asarray(image, dtype=np.float32)
    if bgr.shape[-1] != 3:
        raise ValueError(f'expected B, G, R in the last axis, got shape {bgr.shape}')
    # One linear map per pixel (rows: I1, I2, I3; columns: B, G, R).
    return (bgr.reshape(-1, 3) @ _OHTA.T).reshape(bgr.shape)


def has_colour(image: np.ndarray) -> bool:
    """Whether an image carries chromaticity: three channels that are not all equal.

    A grey-level camera's frames converted to BGR have equal channels; no skin can be found
    in them.
    """
    if image.ndim != 3 or image.shape[2] != 3:
        return False
    return not (np.array_equal(image[..., 0], image[..., 1]) and np.array_equal(image[..., 1], image[..., 2]))


@dataclass(frozen=True)
class SkinClass:
    """One learnt skin class: a Gaussian cluster in the (I2, I3) plane.

    Attributes:
        mean: ``(2,)`` mean I2, I3.
        covariance: ``(2, 2)`` covariance of I2, I3 of the class's samples.
    """

    mean: np.ndarray
    covariance: np.ndarray

    @functools.cached_property
    def _inverse(self) -> np.ndarray:
        return np.linalg.inv(self.covariance)

    def distance(self, chroma: np.ndarray) -> np.ndarray:
        """Mahalanobis distance of ``(..., 2)`` (I2, I3) values to the class; shape ``(...)``."""
        delta = np.asarray(chroma, dtype=np.float64) - self.mean
        (a, b), (c, d) = self._inverse
        du, dv = delta[..., 0], delta[..., 1]
        # The 2x2 quadratic form written out: a three-operand einsum took 0.1 ms per class and call.
        return np.sqrt(np.maximum(a * du * du + (b + c) * du * dv + d * dv * dv, 0.0))


@dataclass(frozen=True)
class SkinModel:
    """The learnt skin classes of §3.2.

    Attributes:
        classes: The skin classes.
        match_distance: Mahalanobis distance within which a colour belongs to a class; set
            in training so that a chosen fraction of the skin samples falls within it.
        notes: Where the model comes from and how it scored in training (free text).
    """

    classes: tuple[SkinClass, ...]
    match_distance: float
    notes: dict = field(default_factory=dict, compare=False)

    def distance(self, chroma: np.ndarray) -> np.ndarray:
        """Distance of ``(..., 2)`` (I2, I3) values to the nearest class; shape ``(...)``."""
        return self._nearest(chroma)[0]

    @functools.cached_property
    def distance_table(self) -> np.ndarray:
        """Distance to the nearest class of every (I2, I3) that 8-bit B, G, R can give.

        ``(511, 1021) float32``, indexed by ``(R - B + 255, 2G - R - B + 510)``: I2 and I3 are
        those integers over 2 and 4, so the table is exact for every pixel.
        """
        i2, i3 = np.meshgrid(np.arange(-255, 256) / 2.0, np.arange(-510, 511) / 4.0, indexing='ij')
        return self.distance(np.stack([i2, i3], axis=-1)).astype(np.float32)

    def nearest(self, chroma: np.ndarray) -> np.ndarray:
        """Index of the nearest class for ``(..., 2)`` (I2, I3) values; shape ``(...)``."""
        return self._nearest(chroma)[1]

    def _nearest(self, chroma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Distance to the nearest class and its index, as :meth:`distance` and :meth:`nearest`."""
        chroma = np.asarray(chroma, dtype=np.float64)
        shape = chroma.shape[:-1]
        # One pass over the values in numba: numpy's per-class arrays took 0.3 ms for the
        # 4,800 cells of a 320x240 frame.
        distances, indices = _nearest_class(np.ascontiguousarray(chroma.reshape(-1, 2)), *self._arrays)
        return distances.reshape(shape), indices.reshape(shape)

    @functools.cached_property
    def _arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """The classes' ``(K, 2)`` means and ``(K, 2, 2)`` inverse covariances."""
        return np.array([c.mean for c in self.classes], dtype=np.float64), np.array([c._inverse for c in self.classes])

    def to_json(self) -> str:
        """The model as JSON (the shipped data file's format)."""
        return json.dumps(
            {
                'match_distance': self.match_distance,
                'classes': [
                    {'mean': c.mean.round(4).tolist(), 'covariance': c.covariance.round(4).tolist()}
                    for c in self.classes
                ],
                'notes': self.notes,
            },
            indent=1,
        )

    @classmethod
    def from_json(cls, text: str) -> SkinModel:
        """Parse :meth:`to_json` output.

        Raises:
            ValueError: Malformed JSON, or classes that are not proper Gaussians.
        """
        try:
            spec = json.loads(text)
            classes = tuple(
                SkinClass(np.asarray(c['mean'], dtype=np.float64), np.asarray(c['covariance'], dtype=np.float64))
                for c in spec['classes']
            )
            match_distance = float(spec['match_distance'])
        except (ValueError, KeyError, TypeError) as err:
            raise ValueError(f'malformed skin model: {err}') from err
        if not classes or match_distance <= 0:
            raise ValueError('a skin model needs at least one class and match_distance > 0')
        for c in classes:
            if c.mean.shape != (2,) or c.covariance.shape != (2, 2) or np.any(np.linalg.eigvalsh(c.covariance) <= 0):
                raise ValueError('each skin class needs a (2,) mean and a positive definite (2, 2) covariance')
        return cls(classes, match_distance, dict(spec.get('notes', {})))

    @classmethod
    def load(cls, path: str | Path) -> SkinModel:
        """Load a model file written by ``human_tracker train-skin``.

        Raises:
            ValueError: The file is missing or malformed; the message names it.
        """
        try:
            return cls.from_json(Path(path).read_text())
        except (OSError, ValueError) as err:
            raise ValueError(f'cannot load skin model {path}: {err}') from err


@numba.njit(cache=True, nogil=True)
def _nearest_class(chroma: np.ndarray, means: np.ndarray, inverses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mahalanobis distance of ``(N, 2)`` (I2, I3) values to the nearest of the classes with
    ``(K, 2)`` means and ``(K, 2, 2)`` inverse covariances, and that class's index (the first
    of equals); the arithmetic of :meth:`SkinClass.distance`."""
    count = chroma.shape[0]
    distances = np.empty(count, dtype=np.float64)
    indices = np.empty(count, dtype=np.int64)
    for i in range(count):
        best = np.inf
        index = 0
        for k in range(means.shape[0]):
            du, dv = chroma[i, 0] - means[k, 0], chroma[i, 1] - means[k, 1]
            inverse = inverses[k]
            squared = inverse[0, 0] * du * du + (inverse[0, 1] + inverse[1, 0]) * du * dv + inverse[1, 1] * dv * dv
            distance = np.sqrt(max(squared, 0.0))
            if distance < best:
                best, index = distance, k
        distances[i] = best
        indices[i] = index
    return distances, indices


def default_skin_model() -> SkinModel:
    """The model shipped in the package (trained on the UCI skin samples, see its notes)."""
    return SkinModel.from_json(resources.files('human_tracker.data').joinpath('skin_model.json').read_text())


def train_skin_model(
    bgr: np.ndarray,
    is_skin: np.ndarray,
    *,
    num_classes: int = 4,
    skin_coverage: float = 0.95,
    seed: int = 0,
) -> SkinModel:
    """Learn skin classes from labelled colour samples (the paper's training phase).

    The skin samples' (I2, I3) are split into ``num_classes`` clusters by k-means; each
    class is the Gaussian (mean, covariance) of its cluster. ``match_distance`` is the
    Mahalanobis distance to the nearest class within which ``skin_coverage`` of the skin
    samples fall.

    Args:
        bgr: ``(M, 3)`` sample colours, B, G, R order, 0-255.
        is_skin: ``(M,) bool``, True for skin samples.
        num_classes: Number of skin classes (clusters).
        skin_coverage: Fraction of skin samples the classes must cover, in (0, 1).
        seed: Seed of the k-means initialisation.

    Returns:
        The model; its notes record the sample counts and the fraction of non-skin samples
        that fall within ``match_distance`` (the false-positive rate per pixel).
    """
    is_skin = np.asarray(is_skin, dtype=bool)
    chroma = ohta(np.asarray(bgr, dtype=np.float32))[:, 1:].astype(np.float64)
    skin = chroma[is_skin]
    if skin.shape[0] < 10 * num_classes:
        raise ValueError(f'need at least {10 * num_classes} skin samples, got {skin.shape[0]}')
    if not 0.0 < skin_coverage < 1.0:
        raise ValueError(f'skin_coverage must be in (0, 1), got {skin_coverage}')
    from scipy.cluster.vq import kmeans2  # here: a second's import a node answering --help need not pay

    _, labels = kmeans2(skin, num_classes, minit='++', seed=np.random.default_rng(seed))
    classes = tuple(
        SkinClass(skin[labels == k].mean(axis=0), np.cov(skin[labels == k].T) + np.eye(2))
        for k in range(num_classes)
        if np.count_nonzero(labels == k) > 2
    )
    model = SkinModel(classes, 1.0)
    match_distance = float(np.quantile(model.distance(skin), skin_coverage))
    non_skin = chroma[~is_skin]
    accepted = float(np.mean(model.distance(non_skin) <= match_distance)) if non_skin.size else float('nan')
    notes = {
        'skin_samples': int(skin.shape[0]),
        'non_skin_samples': int(non_skin.shape[0]),
        'skin_coverage': skin_coverage,
        'non_skin_accepted': round(accepted, 4),
    }
    return SkinModel(classes, match_distance, notes)


REGION_METHODS = ('cells', 'pixels')


@dataclass
class SkinParameters:
    """Constants of the two-phase segmentation.

    Attributes:
        max_exposure_gain: A dark frame is brightened (its 99th percentile brought to 255) by
            at most this factor before its colours are read
            (:func:`~human_tracker.vision.exposure.normalise_exposure`; 1: never, the paper).
            Skin's (I2, I3) scale with the light: ``hand2`` with its frames at 0.4 of their
            brightness (a dim room) keeps no skin label without it, and its hand is lost
            within a few frames.
        colour_blur: Standard deviation of a Gaussian the image is smoothed with before its
            colours are read, camera pixels (0: none, the paper). It clears the specks of
            labels a compressed camera's colours scatter over a room, and a skin region's
            pixels scattered out of its modes, but also blends a crisp border between two
            skin-like colours, so it is off by default (docs/evaluation.md).
        regions: How phase 1 finds the regions: ``pixels`` (seeds grown by hysteresis) or
            ``cells`` (the paper's candidate cells).
        seed_scale: With ``pixels``, a pixel within this many ``match_distance`` of a class
            is a seed.
        grow_scale: With ``pixels``, a region grows from its seeds through 8-connected
            pixels within this many ``match_distance`` of a class.
        cell_size: Side of the square cells of the first partition, camera pixels.
        min_region_cells: Smallest merged region, in cells, that is kept.
        histogram_bins: Bins of each local I1, I2, I3 histogram.
        histogram_smoothing: Standard deviation (bins) of the Gaussian smoothing of the
            histograms before peaks and valleys are found.
        peak_fraction: A peak lower than this fraction of a histogram's highest peak is not
            a principal peak.
        support_fraction: A peak's mode extends down its slopes to this fraction of its height
            (or to a valley).
        max_peaks: Largest number of principal peaks kept per histogram.
        min_cluster_pixels: Clusters with fewer camera pixels are not labelled skin.
        variance_ratio: Largest ratio between a cluster's (I2, I3) variance and the matching
            class's variance for the cluster to be skin.
        match_scale: Multiplies the model's ``match_distance`` (above 1: more permissive).
        split_mixed: With ``cells``, a cluster of at least ``min_mixed_pixels`` refused is
            split in two by 2-means in (I2, I3) and each part judged as a cluster; a part
            accepted is labelled :data:`MIXED_SKIN` on the region's own cells (not on the
            one-cell border it was grown by). A fist before a khaki jacket, or a hand before
            the face, makes one region whose I1, I2, I3 histograms show one broad peak: its
            cluster holds the skin and the jacket, too spread for a class, and neither is
            labelled (hand2, frames 140-163: no skin, so the hand was lost on every run).
        min_mixed_pixels: Smallest mixed cluster that is split, camera pixels.
        merge_distance: With ``cells``, two adjacent candidate cells join one region only when
            their mean (I2, I3) lie within this distance of each other (0: any two adjacent
            cells, the paper). A hand before a skin-coloured surface of another shade then
            makes a region, and clusters, of its own instead of one mixed cluster with the
            surface (opt-in: docs/evaluation.md).
    """

    max_exposure_gain: float = MAX_EXPOSURE_GAIN
    colour_blur: float = 0.0
    regions: str = 'cells'
    seed_scale: float = 1.0
    grow_scale: float = 2.5
    cell_size: int = 8
    min_region_cells: int = 2
    histogram_bins: int = 64
    histogram_smoothing: float = 1.0
    peak_fraction: float = 0.1
    support_fraction: float = 0.1
    max_peaks: int = 3
    min_cluster_pixels: int = 16
    variance_ratio: float = 6.0
    match_scale: float = 1.5
    split_mixed: bool = True
    min_mixed_pixels: int = 64
    merge_distance: float = 0.0

    def validate(self) -> None:
        """Raise ValueError naming the first parameter out of its range."""
        checks = [
            (self.max_exposure_gain >= 1, f'max_exposure_gain must be >= 1, got {self.max_exposure_gain}'),
            (self.colour_blur >= 0, f'colour_blur must be >= 0, got {self.colour_blur}'),
            (self.regions in REGION_METHODS, f'regions must be one of {", ".join(REGION_METHODS)}: {self.regions!r}'),
            (
                0 < self.seed_scale <= self.grow_scale,
                f'need 0 < seed_scale <= grow_scale: {self.seed_scale}, {self.grow_scale}',
            ),
            (self.cell_size >= 2, f'cell_size must be >= 2, got {self.cell_size}'),
            (self.min_region_cells >= 1, f'min_region_cells must be >= 1, got {self.min_region_cells}'),
            (self.histogram_bins >= 4, f'histogram_bins must be >= 4, got {self.histogram_bins}'),
            (self.histogram_smoothing >= 0, f'histogram_smoothing must be >= 0, got {self.histogram_smoothing}'),
            (0.0 <= self.peak_fraction <= 1.0, f'peak_fraction must be in [0, 1], got {self.peak_fraction}'),
            (0.0 <= self.support_fraction < 1.0, f'support_fraction must be in [0, 1), got {self.support_fraction}'),
            (1 <= self.max_peaks <= 8, f'max_peaks must be in [1, 8], got {self.max_peaks}'),
            (self.min_cluster_pixels >= 1, f'min_cluster_pixels must be >= 1, got {self.min_cluster_pixels}'),
            (self.variance_ratio > 0, f'variance_ratio must be > 0, got {self.variance_ratio}'),
            (self.match_scale > 0, f'match_scale must be > 0, got {self.match_scale}'),
            (self.min_mixed_pixels >= 1, f'min_mixed_pixels must be >= 1, got {self.min_mixed_pixels}'),
            (self.merge_distance >= 0, f'merge_distance must be >= 0, got {self.merge_distance}'),
        ]
        for ok, message in checks:
            if not ok:
                raise ValueError(message)

    def scaled(self, factor: float) -> SkinParameters:
        """The same segmentation on images resized by ``factor``: lengths and cluster areas scaled."""
        if factor == 1.0:
            return self
        return replace(
            self,
            colour_blur=self.colour_blur * factor,
            cell_size=max(2, round(self.cell_size * factor)),
            min_cluster_pixels=max(1, round(self.min_cluster_pixels * factor**2)),
            min_mixed_pixels=max(1, round(self.min_mixed_pixels * factor**2)),
        )


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


def histogram_modes(
    histogram: np.ndarray,
    *,
    smoothing: float = 1.0,
    peak_fraction: float = 0.1,
    support_fraction: float = 0.1,
    max_peaks: int = 3,
) -> np.ndarray:
    """Phase 2: which principal peak (mode) of a histogram each bin belongs to.

    A principal peak is a local maximum of the smoothed histogram reaching ``peak_fraction``
    of the highest one (the ``max_peaks`` highest are kept). A peak's mode runs down both of
    its slopes until a valley (the histogram rises again) or until the histogram falls
    below ``support_fraction`` of the peak's height. Bins outside every mode hold the
    spread-out rest of the region (background around the skin, usually), which gets its
    own label so that it does not dilute a mode's mean and variance.

    Args:
        histogram: ``(B,)`` counts.
        smoothing: Standard deviation, bins, of the Gaussian smoothing (0: none).
        peak_fraction: Height, relative to the highest peak, a principal peak must reach.
        support_fraction: Height, relative to its peak, down to which a mode extends.
        max_peaks: Largest number of modes.

    Returns:
        ``(B,) int64``: the mode of each bin, 0 for the highest peak, 1 for the next, ...;
        ``max_peaks`` for bins in no mode.
    """
    return _row_modes(np.asarray(histogram)[None, :], smoothing, peak_fraction, support_fraction, max_peaks)[0]


def _row_modes(
    histograms: np.ndarray, smoothing: float, peak_fraction: float, support_fraction: float, max_peaks: int
) -> np.ndarray:
    """:func:`histogram_modes` of each row of ``(R, B)`` histograms."""
    smooth = np.asarray(histograms, dtype=np.float64)
    if smoothing > 0:
        from scipy.ndimage import gaussian_filter1d  # here, as kmeans2

        smooth = gaussian_filter1d(smooth, smoothing, axis=1, mode='constant')
    return _modes(smooth, peak_fraction, support_fraction, max_peaks)


@numba.njit(cache=True, nogil=True)
def _modes(smooth: np.ndarray, peak_fraction: float, support_fraction: float, max_peaks: int) -> np.ndarray:
    """The modes of each row of ``(R, B)`` smoothed histograms (see :func:`histogram_modes`)."""
    rows, bins = smooth.shape
    modes = np.full((rows, bins), max_peaks, dtype=np.int64)
    for r in range(rows):
        h = smooth[r]
        highest = h.max()
        peaks = np.empty(bins, dtype=np.int64)
        found = 0
        for b in range(bins):
            left = h[b - 1] if b > 0 else -1.0
            right = h[b + 1] if b < bins - 1 else -1.0
            if h[b] > left and h[b] >= right and h[b] > 0 and h[b] >= peak_fraction * highest:
                peaks[found] = b
                found += 1
        # Highest first; a stable sort keeps the lower bin first among equal heights.
        order = peaks[:found][np.argsort(-h[peaks[:found]], kind='mergesort')]
        for mode in range(min(max_peaks, found)):
            peak = order[mode]
            floor = support_fraction * h[peak]
            modes[r, peak] = mode
            for direction in (-1, 1):
                b = peak + direction
                while 0 <= b < bins and modes[r, b] == max_peaks and floor <= h[b] <= h[b - direction]:
                    modes[r, b] = mode
                    b += direction
    return modes


@numba.njit(cache=True, nogil=True)
def _ohta_pixel(pixel: np.ndarray) -> tuple[float, float, float]:
    """I1, I2, I3 of one BGR pixel (as :func:`ohta`)."""
    b, g, r = float(pixel[0]), float(pixel[1]), float(pixel[2])
    return (r + g + b) / 3.0, (r - b) / 2.0, (2.0 * g - r - b) / 4.0


@numba.njit(cache=True, nogil=True)
def _pixel_bins(pixel: np.ndarray, bins: int) -> tuple[int, int, int]:
    """Histogram bins of a BGR pixel's I1, I2, I3 (ranges [0, 255], [-127.5, 127.5] twice)."""
    i1, i2, i3 = _ohta_pixel(pixel)
    scale = bins / 255.0
    return (
        min(int(i1 * scale), bins - 1),
        min(int((i2 + 127.5) * scale), bins - 1),
        min(int((i3 + 127.5) * scale), bins - 1),
    )


@numba.njit(cache=True, nogil=True)
def _region_histograms(image: np.ndarray, region: np.ndarray, count: int, bins: int) -> np.ndarray:
    """``(count, 3, bins)`` I1, I2, I3 histograms of each region (labels 1..count in ``region``)."""
    histograms = np.zeros((count, 3, bins), dtype=np.float64)
    height, width = region.shape
    for v in range(height):
        for u in range(width):
            r = region[v, u]
            if r > 0:
                b1, b2, b3 = _pixel_bins(image[v, u], bins)
                histograms[r - 1, 0, b1] += 1.0
                histograms[r - 1, 1, b2] += 1.0
                histograms[r - 1, 2, b3] += 1.0
    return histograms


@numba.njit(cache=True, nogil=True)
def _cluster_statistics(
    image: np.ndarray, region: np.ndarray, lookup: np.ndarray, bins: int, per_mode: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each pixel's cluster (region and I1, I2, I3 modes; -1 outside regions), and per cluster
    the pixel count and the sums of I2, I3 and of their squares."""
    height, width = region.shape
    size = lookup.shape[0] * per_mode**3
    clusters = np.full((height, width), -1, dtype=np.int64)
    n = np.zeros(size)
    sums = np.zeros((size, 2))
    squares = np.zeros((size, 2))
    for v in range(height):
        for u in range(width):
            r = region[v, u]
            if r == 0:
                continue
            b1, b2, b3 = _pixel_bins(image[v, u], bins)
            m = lookup[r - 1]
            cluster = (r - 1) * per_mode**3 + (m[0, b1] * per_mode + m[1, b2]) * per_mode + m[2, b3]
            clusters[v, u] = cluster
            _, i2, i3 = _ohta_pixel(image[v, u])
            n[cluster] += 1.0
            sums[cluster, 0] += i2
            sums[cluster, 1] += i3
            squares[cluster, 0] += i2 * i2
            squares[cluster, 1] += i3 * i3
    return clusters, n, sums, squares


@numba.njit(cache=True, nogil=True)
def _two_means(
    image: np.ndarray, clusters: np.ndarray, mixed: np.ndarray, iterations: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each cluster flagged in ``mixed`` split in two by 2-means on its pixels' (I2, I3).

    The two sides start on either side of the cluster's principal axis through its mean and
    then, ``iterations`` times, each pixel goes to the side whose mean is nearer.

    Returns:
        The mixed clusters' pixels (``(N,)`` rows, columns and part ``2 c + side``), and per
        part (``2 C``) the pixel count and the sums of I2, I3 and of their squares.
    """
    height, width = clusters.shape
    size = mixed.shape[0]
    count = 0
    for v in range(height):
        for u in range(width):
            c = clusters[v, u]
            if c >= 0 and mixed[c]:
                count += 1
    rows = np.empty(count, np.int64)
    cols = np.empty(count, np.int64)
    owner = np.empty(count, np.int64)
    chroma = np.empty((count, 2))
    moments = np.zeros((size, 6))  # n, sums of I2, I3, I2², I3², I2 I3
    k = 0
    for v in range(height):
        for u in range(width):
            c = clusters[v, u]
            if c >= 0 and mixed[c]:
                _, i2, i3 = _ohta_pixel(image[v, u])
                rows[k], cols[k], owner[k] = v, u, c
                chroma[k, 0], chroma[k, 1] = i2, i3
                moments[c, 0] += 1.0
                moments[c, 1] += i2
                moments[c, 2] += i3
                moments[c, 3] += i2 * i2
                moments[c, 4] += i3 * i3
                moments[c, 5] += i2 * i3
                k += 1
    # The principal axis of each cluster's (I2, I3), through its mean.
    axis = np.zeros((size, 4))  # mean I2, mean I3, cos, sin
    for c in range(size):
        if moments[c, 0] > 0:
            m = moments[c] / moments[c, 0]
            angle = 0.5 * np.arctan2(2.0 * (m[5] - m[1] * m[2]), (m[3] - m[1] * m[1]) - (m[4] - m[2] * m[2]))
            axis[c, 0], axis[c, 1], axis[c, 2], axis[c, 3] = m[1], m[2], np.cos(angle), np.sin(angle)
    side = np.empty(count, np.int64)
    for j in range(count):
        a = axis[owner[j]]
        side[j] = 1 if (chroma[j, 0] - a[0]) * a[2] + (chroma[j, 1] - a[1]) * a[3] > 0 else 0
    centres = np.zeros((size, 2, 2))
    counts = np.zeros((size, 2))
    for _ in range(iterations):
        centres[:] = 0.0
        counts[:] = 0.0
        for j in range(count):
            c, t = owner[j], side[j]
            centres[c, t, 0] += chroma[j, 0]
            centres[c, t, 1] += chroma[j, 1]
            counts[c, t] += 1.0
        for c in range(size):
            for t in range(2):
                if counts[c, t] > 0.0:
                    centres[c, t] /= counts[c, t]  # the side's mean
        for j in range(count):
            c = owner[j]
            if counts[c, 0] == 0.0 or counts[c, 1] == 0.0:
                continue  # one side is empty: nothing to split
            d0 = (chroma[j, 0] - centres[c, 0, 0]) ** 2 + (chroma[j, 1] - centres[c, 0, 1]) ** 2
            d1 = (chroma[j, 0] - centres[c, 1, 0]) ** 2 + (chroma[j, 1] - centres[c, 1, 1]) ** 2
            side[j] = 1 if d1 < d0 else 0
    part = 2 * owner + side
    n = np.zeros(2 * size)
    sums = np.zeros((2 * size, 2))
    squares = np.zeros((2 * size, 2))
    for j in range(count):
        n[part[j]] += 1.0
        for d in range(2):
            sums[part[j], d] += chroma[j, d]
            squares[part[j], d] += chroma[j, d] * chroma[j, d]
    return rows, cols, part, n, sums, squares


def _accepted(n: np.ndarray, sums: np.ndarray, squares: np.ndarray, model: SkinModel, p: SkinParameters) -> np.ndarray:
    """Which clusters (pixel counts, sums of (I2, I3) and of their squares) are skin: populated,
    their mean within a class, their variance within ``variance_ratio`` of that class's."""
    skin = n >= p.min_cluster_pixels
    # Most (region, mode) clusters are empty: judge the populated ones only.
    populated = np.flatnonzero(skin)
    means = sums[populated] / n[populated, None]
    variances = np.maximum(squares[populated] / n[populated, None] - means**2, 0.0)
    class_variances = np.array([np.diag(c.covariance) for c in model.classes])[model.nearest(means)]
    skin[populated] = (model.distance(means) <= model.match_distance * p.match_scale) & np.all(
        variances <= p.variance_ratio * class_variances, axis=1
    )
    return skin


def segment_skin(
    image: np.ndarray,
    model: SkinModel,
    parameters: SkinParameters | None = None,
) -> np.ndarray:
    """Skin labels of a colour image (§3.2, both phases).

    Args:
        image: ``(H, W, 3) uint8`` BGR image.
        model: The learnt skin classes.
        parameters: Segmentation constants (defaults when None).

    Returns:
        ``(H, W) uint8``: :data:`SKIN` (255) on the clusters labelled skin,
        :data:`MIXED_SKIN` (128) on the parts of mixed clusters labelled skin
        (``split_mixed``), 0 elsewhere.
    """
    p = parameters or SkinParameters()
    if image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f'skin segmentation needs a (H, W, 3) colour image, got shape {image.shape}')
    image = normalise_exposure(np.ascontiguousarray(image, dtype=np.uint8), p.max_exposure_gain)
    if p.colour_blur > 0:
        image = cv2.GaussianBlur(image, (0, 0), p.colour_blur)
    height, width = image.shape[:2]
    if p.regions == 'pixels':
        # Every pixel of these regions is already within grow_scale of a class: phase 2's
        # test of a cluster's mean would keep them all (on HGR, dilating the regions for it
        # to judge their borders too lost recall and gained no precision).
        labels, _ = hysteresis_regions(image, model, p.seed_scale, p.grow_scale)
        return (labels > 0).astype(np.uint8) * 255
    chroma = cell_chroma(image, p.cell_size)
    cells, count = merge_cells(
        candidate_cells(chroma, model, p.match_scale), p.min_region_cells, chroma, p.merge_distance
    )
    if count == 0:
        return np.zeros((height, width), dtype=np.uint8)
    # Each region grows by one cell (the dilation keeps the larger label where two meet) so
    # that pixels of skin in cells that were mostly background are looked at too.
    grown = cv2.dilate(cells.astype(np.uint16), np.ones((3, 3), np.uint8))
    region = np.zeros((height, width), dtype=np.uint16)
    extent = (cells.shape[1] * p.cell_size, cells.shape[0] * p.cell_size)
    region[: extent[1], : extent[0]] = cv2.resize(grown, extent, interpolation=cv2.INTER_NEAREST)
    histograms = _region_histograms(image, region, count, p.histogram_bins).reshape(count * 3, -1)
    lookup = _row_modes(histograms, p.histogram_smoothing, p.peak_fraction, p.support_fraction, p.max_peaks)
    lookup = lookup.reshape(count, 3, -1)
    # A pixel's cluster: its region and its mode in each of I1, I2, I3 (max_peaks + 1 each).
    clusters, n, sums, squares = _cluster_statistics(image, region, lookup, p.histogram_bins, p.max_peaks + 1)
    is_skin = _accepted(n, sums, squares, model, p)
    # Cluster -1 (outside every region) reads the appended False.
    labels = np.append(is_skin, False)[clusters].astype(np.uint8) * SKIN
    mixed = ~is_skin & (n >= p.min_mixed_pixels)
    if p.split_mixed and mixed.any():
        rows, cols, part, part_n, part_sums, part_squares = _two_means(image, clusters, mixed, MIXED_ITERATIONS)
        # On the region's own cells, not on the border it was grown by.
        on_cells = (rows < extent[1]) & (cols < extent[0])
        on_cells[on_cells] = cells[rows[on_cells] // p.cell_size, cols[on_cells] // p.cell_size] > 0
        taken = _accepted(part_n, part_sums, part_squares, model, p)[part] & on_cells
        labels[rows[taken], cols[taken]] = MIXED_SKIN
    return labels


@dataclass
class SkinSegmenter:
    """Segmentation with online adaptation of the skin classes to the tracked target.

    Attributes:
        prior: The learnt model; adaptation never strays further than ``max_drift`` from it.
        parameters: Segmentation constants.
        adaptation_rate: Weight of the newest observation when the classes adapt, in [0, 1];
            0 disables adaptation.
        max_drift: Largest Mahalanobis distance (in the prior class's metric) an adapted class
            mean may move from its prior mean.
        model: The current, possibly adapted, model.
    """

    prior: SkinModel
    parameters: SkinParameters = field(default_factory=SkinParameters)
    adaptation_rate: float = 0.0
    max_drift: float = 1.5
    model: SkinModel = field(init=False)

    def __post_init__(self) -> None:
        self.parameters.validate()
        if not 0.0 <= self.adaptation_rate <= 1.0:
            raise ValueError(f'adaptation_rate must be in [0, 1], got {self.adaptation_rate}')
        self.model = self.prior

    def segment(self, image: np.ndarray, scale: float = 1.0) -> np.ndarray:
        """Skin labels of ``image`` with the current model; see :func:`segment_skin`.

        Args:
            image: ``(H, W, 3) uint8`` BGR frame, possibly reduced to the working resolution.
            scale: Pixels of ``image`` per camera pixel (the parameters' lengths are in
                camera pixels; :func:`~human_tracker.vision.resolution.working_scale`).
        """
        return segment_skin(image, self.model, self.parameters.scaled(scale))

    def adapt(self, image: np.ndarray, region: np.ndarray, skin: np.ndarray) -> bool:
        """Move the nearest class towards the skin pixels of the tracked region.

        Args:
            image: ``(H, W, 3) uint8`` BGR frame.
            region: ``(H, W)`` non-zero inside the tracked target.
            skin: ``(H, W)`` this frame's skin labels (only pixels labelled skin are used,
                so background inside the region does not pull the classes away).

        Returns:
            Whether the model changed (False when adaptation is off, too few pixels, or the
            region's colour lies further than ``max_drift`` from every prior class).
        """
        selected = (np.asarray(region) > 0) & (np.asarray(skin) > 0)
        if self.adaptation_rate <= 0 or np.count_nonzero(selected) < self.parameters.min_cluster_pixels:
            return False
        # The colours as the segmentation reads them.
        image = normalise_exposure(np.asarray(image, dtype=np.uint8), self.parameters.max_exposure_gain)
        chroma = ohta(image[selected])[:, 1:].astype(np.float64)
        mean = chroma.mean(axis=0)
        k = int(self.prior.nearest(mean))
        prior = self.prior.classes[k]
        current = self.model.classes[k]
        rate = self.adaptation_rate
        adapted_mean = (1 - rate) * current.mean + rate * mean
        if prior.distance(adapted_mean) > self.max_drift:
            return False
        covariance = (1 - rate) * current.covariance + rate * (np.cov(chroma.T) + np.eye(2))
        classes = list(self.model.classes)
        classes[k] = SkinClass(adapted_mean, covariance)
        self.model = replace(self.model, classes=tuple(classes))
        return True

    def reset(self) -> None:
        """Forget the adaptation (back to the learnt classes)."""
        self.model = self.prior
