"""The skin segmentation's constants."""

from __future__ import annotations

from dataclasses import dataclass, replace

from human_tracker.vision.checks import parameter
from human_tracker.vision.cues.exposure import MAX_EXPOSURE_GAIN

REGION_METHODS = ('cells', 'pixels')


@dataclass
class SkinParameters:
    """Constants of the two-phase segmentation.

    Attributes:
        max_exposure_gain: A dark frame is brightened (its 99th percentile brought to 255) by
            at most this factor before its colours are read
            (:func:`~human_tracker.vision.cues.exposure.normalise_exposure`; 1: never, the paper).
            Skin's (I2, I3) scale with the light: ``hand2`` with its frames at 0.4 of their
            brightness (a dim room) keeps no skin label without it, and its hand is lost
            within a few frames.
        colour_blur: Standard deviation of a Gaussian the image is smoothed with before its
            colours are read, camera pixels (0: none, the paper). It clears the specks of
            labels a compressed camera's colours scatter over a room, and a skin region's
            pixels scattered out of its modes, but also blends a crisp border between two
            skin-like colours, so it is off by default (docs/decisions/skin-labels.md).
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
            surface (opt-in: docs/decisions/skin-cells-merged-by-colour.md).
    """

    max_exposure_gain: float = parameter(
        MAX_EXPOSURE_GAIN,
        'Largest gain brightening a dark frame before its colours are read (1: none).',
        low=1.0,
        high=16.0,
    )
    colour_blur: float = parameter(
        0.0,
        'Gaussian smoothing of the colours before they are read, sigma in pixels (0: none; 1 helps a '
        'compressed camera).',
        low=0.0,
        high=20.0,
    )
    regions: str = parameter(
        'cells', 'Phase 1: cells (the paper) or pixels (seed pixels grown by hysteresis: small regions).'
    )
    seed_scale: float = parameter(
        1.0, 'regions: pixels: seeds lie within this many match distances of a class.', low=0.01, high=100.0
    )
    grow_scale: float = parameter(
        2.5, 'regions: pixels: regions grow through pixels within this many.', low=0.01, high=100.0
    )
    cell_size: int = parameter(8, 'Side of the square cells of the first partition, pixels.', low=2, high=256)
    min_region_cells: int = parameter(
        2, 'Smallest merged region of candidate cells that is kept, cells.', low=1, high=100000
    )
    histogram_bins: int = parameter(64, 'Bins of each local I1, I2, I3 histogram.', low=4, high=1024)
    histogram_smoothing: float = parameter(1.0, 'Gaussian smoothing of the local histograms, bins.', low=0.0, high=50.0)
    peak_fraction: float = parameter(
        0.1, 'Height (fraction of the highest) a principal histogram peak must reach.', low=0.0, high=1.0
    )
    support_fraction: float = parameter(
        0.1, 'Height (fraction of its peak) down to which a mode extends.', low=0.0, high=0.99
    )
    max_peaks: int = parameter(3, 'Largest number of principal peaks per histogram.', low=1, high=8)
    min_cluster_pixels: int = parameter(16, 'Clusters with fewer pixels are not skin.', low=1, high=10000000)
    variance_ratio: float = parameter(
        6.0, "Largest ratio of a cluster's (I2, I3) variance to its class's.", low=0.01, high=1000.0
    )
    match_scale: float = parameter(
        1.5, "Multiplies the model's match distance (> 1: more permissive).", low=0.01, high=100.0
    )
    split_mixed: bool = parameter(
        True, 'Split a refused cluster in two in (I2, I3); label the part a class accepts 128.'
    )
    min_mixed_pixels: int = parameter(64, 'Smallest refused cluster that is split, pixels.', low=1, high=10000000)
    merge_distance: float = parameter(
        0.0,
        'Adjacent candidate cells join one region only within this (I2, I3) distance; 0: any (the paper); 10 '
        'keeps a hand apart from a skin-coloured surface of another shade.',
        low=0.0,
        high=1000.0,
    )

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
