"""The skin segmentation of a frame (both phases of §3.2), and a segmenter whose classes can
adapt to the tracked region."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import cv2
import numpy as np

from human_tracker.vision.cues.exposure import normalise_exposure
from human_tracker.vision.cues.resolution import to_working, working_scale
from human_tracker.vision.cues.skin.clusters import _cluster_statistics, _region_histograms, _row_modes, _two_means
from human_tracker.vision.cues.skin.model import MIXED_SKIN, SKIN, SkinClass, SkinModel, ohta
from human_tracker.vision.cues.skin.parameters import SkinParameters
from human_tracker.vision.cues.skin.regions import candidate_cells, cell_chroma, hysteresis_regions, merge_cells

# 2-means iterations of a mixed cluster's split.
MIXED_ITERATIONS = 5


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


def segment_frame(
    image: np.ndarray, model: SkinModel, parameters: SkinParameters | None = None, width: int = 320
) -> np.ndarray:
    """Skin labels (:func:`segment_skin`) of a BGR frame as the skin stage computes them: at
    working ``width`` (0: full size), lengths scaled, then resized to the frame's size."""
    parameters = parameters or SkinParameters()
    scale = working_scale(image.shape[1], width)
    labels = segment_skin(to_working(image, width), model, parameters.scaled(scale))
    return cv2.resize(labels, (image.shape[1], image.shape[0]), interpolation=cv2.INTER_NEAREST)


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
                camera pixels; :func:`~human_tracker.vision.cues.resolution.working_scale`).
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
