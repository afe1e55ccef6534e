"""Colour appearance likelihood (Pérez, Hue, Vermaak, Gangnet, ECCV 2002), as fused with the
silhouette by the paper's authors in their later work (Brèthes et al., ICRA 2004-2005).

The target's region (the box a track started from, or the template's reference region) is
placed on each particle's contour through a :class:`~human_tracker.vision.boxes.BoxRelation`,
split into ``parts`` horizontal bands (head: hair above, face below; the layout a single
histogram would lose), and each band gives a colour histogram over HSV bins:
``hue_bins x saturation_bins`` for coloured pixels and ``value_bins`` for the grey ones
(saturation or value too low for the hue to mean anything; a grey-level camera gives
intensity histograms). Samples are weighted by an Epanechnikov kernel over the region, so the
border, where the background creeps in, counts least.

With q the reference histograms and p a particle's, the Bhattacharyya distance per band is
``D = sqrt(1 - Σ_u sqrt(p_u q_u))`` and the particle's appearance term is

    p_appearance(z | x) ∝ exp(-λ D²),   D² the mean of the bands' squared distances,

λ = ``appearance_gain``. The tracker multiplies it with the shape likelihood of eqs. 1-4
(adds the logarithms). The reference is taken when the track starts and blended with the
estimate's histograms at ``adaptation_rate`` only while the track is confident.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numba
import numpy as np

from human_tracker.vision.boxes import BoxRelation

__all__ = ['AppearanceModel', 'bhattacharyya_distance', 'colour_bins', 'region_histograms']

HUE_BINS = 8
SATURATION_BINS = 8
VALUE_BINS = 8
NUM_BINS = HUE_BINS * SATURATION_BINS + VALUE_BINS
# Below these (of 255) a pixel's hue is noise: it goes to the grey (value) bins.
MIN_SATURATION = 40
MIN_VALUE = 40
GRID = 12  # samples per side of a region


def colour_bins(image: np.ndarray) -> np.ndarray:
    """The histogram bin of every pixel.

    Args:
        image: ``(H, W, 3) uint8`` BGR image, or ``(H, W) uint8`` grey-level image (value
            bins only).

    Returns:
        ``(H, W) uint8`` bin indices in ``[0, NUM_BINS)``: hue-saturation bins first, then
        the value bins of grey pixels.
    """
    if image.ndim == 2:
        value = image.astype(np.uint16) * VALUE_BINS // 256
        return (HUE_BINS * SATURATION_BINS + value).astype(np.uint8)
    hsv = cv2.cvtColor(image, cv2.COLOR_BGR2HSV)  # OpenCV's hue: 0..179
    hue = hsv[..., 0].astype(np.uint16) * HUE_BINS // 180
    saturation = hsv[..., 1].astype(np.uint16) * SATURATION_BINS // 256
    value = hsv[..., 2].astype(np.uint16) * VALUE_BINS // 256
    coloured = (hsv[..., 1] >= MIN_SATURATION) & (hsv[..., 2] >= MIN_VALUE)
    return np.where(coloured, hue * SATURATION_BINS + saturation, HUE_BINS * SATURATION_BINS + value).astype(np.uint8)


def bhattacharyya_distance(p: np.ndarray, q: np.ndarray) -> float:
    """``sqrt(1 - Σ sqrt(p q))`` of two normalised histograms (0: identical, 1: disjoint)."""
    return float(np.sqrt(max(0.0, 1.0 - float(np.sum(np.sqrt(p * q))))))


def _grid(parts: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sample offsets ``(G², 2)`` in a unit box centred on 0, their kernel weights and band."""
    ticks = (np.arange(GRID) + 0.5) / GRID - 0.5
    u, v = np.meshgrid(ticks, ticks)
    offsets = np.column_stack([u.ravel(), v.ravel()])
    kernel = 1.0 - (2.0 * offsets[:, 0]) ** 2 - (2.0 * offsets[:, 1]) ** 2 / 2.0  # Epanechnikov, flatter in v
    band = np.minimum(((offsets[:, 1] + 0.5) * parts).astype(np.int64), parts - 1)
    return offsets, np.clip(kernel, 0.05, None), band


@numba.njit(cache=True, nogil=True)
def _histograms(
    bins: np.ndarray,
    boxes: np.ndarray,
    angles: np.ndarray,
    offsets: np.ndarray,
    kernel: np.ndarray,
    band: np.ndarray,
    parts: int,
    num_bins: int,
) -> np.ndarray:
    """``(P, parts, num_bins)`` normalised histograms of the rotated boxes (cx, cy, w, h)."""
    height, width = bins.shape
    out = np.zeros((boxes.shape[0], parts, num_bins))
    for i in range(boxes.shape[0]):
        c = np.cos(angles[i])
        s = np.sin(angles[i])
        for k in range(offsets.shape[0]):
            du = offsets[k, 0] * boxes[i, 2]
            dv = offsets[k, 1] * boxes[i, 3]
            u = int(boxes[i, 0] + c * du - s * dv)
            v = int(boxes[i, 1] + s * du + c * dv)
            if 0 <= u < width and 0 <= v < height:
                out[i, band[k], bins[v, u]] += kernel[k]
        for b in range(parts):
            total = out[i, b].sum()
            if total > 0:
                out[i, b] /= total
    return out


@numba.njit(cache=True, nogil=True)
def _squared_distances(histograms: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Mean over bands of D² = 1 - Σ sqrt(p q); a band with no sample in the image counts 1."""
    count, parts, num_bins = histograms.shape
    out = np.empty(count)
    for i in range(count):
        total = 0.0
        for b in range(parts):
            coefficient = 0.0
            for u in range(num_bins):
                coefficient += np.sqrt(histograms[i, b, u] * reference[b, u])
            total += max(0.0, 1.0 - coefficient)
        out[i] = total / parts
    return out


def region_histograms(bins: np.ndarray, states: np.ndarray, region: BoxRelation, parts: int = 2) -> np.ndarray:
    """Colour histograms of ``region`` placed on the contours at ``states``.

    Args:
        bins: ``(H, W) uint8`` bin image from :func:`colour_bins`.
        states: ``(P, 4)`` states [x, y, s, θ] in the pixels of ``bins``.
        region: Where the region sits on the contour (template units).
        parts: Horizontal bands of the region, each with its own histogram.

    Returns:
        ``(P, parts, NUM_BINS) float64``, each band's histogram summing to 1 (0 where the
        band lies wholly outside the image).
    """
    states = np.atleast_2d(np.asarray(states, dtype=np.float64))
    x, y, s, theta = states.T
    c, sn = np.cos(theta), np.sin(theta)
    u, v = region.centre
    width, height = region.size
    boxes = np.column_stack([x + s * (c * u - sn * v), y + s * (sn * u + c * v), s * width, s * height])
    offsets, kernel, band = _grid(parts)
    return _histograms(bins, boxes, np.ascontiguousarray(theta), offsets, kernel, band, parts, NUM_BINS)


@dataclass
class AppearanceModel:
    """The reference histograms of one target and where its region sits on the contour.

    Attributes:
        region: The region on the contour, template units.
        reference: ``(parts, NUM_BINS)`` reference histograms q.
    """

    region: BoxRelation
    reference: np.ndarray

    @property
    def parts(self) -> int:
        """Number of horizontal bands."""
        return int(self.reference.shape[0])

    @classmethod
    def learn(cls, bins: np.ndarray, state: np.ndarray, region: BoxRelation, parts: int = 2) -> AppearanceModel:
        """The reference taken from ``region`` on the contour at ``state`` (pixels of ``bins``)."""
        return cls(region, region_histograms(bins, state, region, parts)[0])

    def squared_distances(self, bins: np.ndarray, states: np.ndarray) -> np.ndarray:
        """``(P,)`` D², mean over the bands, of each state's region from the reference, in [0, 1]."""
        return _squared_distances(region_histograms(bins, states, self.region, self.parts), self.reference)

    def adapt(self, bins: np.ndarray, state: np.ndarray, rate: float) -> None:
        """Blend the histograms at ``state`` into the reference: q ← (1 - rate) q + rate p."""
        current = region_histograms(bins, state, self.region, self.parts)[0]
        seen = current.sum(axis=1) > 0
        self.reference[seen] = (1.0 - rate) * self.reference[seen] + rate * current[seen]
