"""Colour appearance likelihood (Pérez, Hue, Vermaak, Gangnet, ECCV 2002), as fused with the
silhouette by the paper's authors in their later work (Brèthes et al., ICRA 2004-2005).

The target's region (the box a track started from, or the template's reference region) is
placed on each particle's contour through a :class:`~human_tracker.vision.geometry.boxes.BoxRelation`,
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
from functools import lru_cache

import cv2
import numba
import numpy as np

from human_tracker.vision.geometry.boxes import BoxRelation

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
    return _hsv_bins(cv2.cvtColor(image, cv2.COLOR_BGR2HSV))  # OpenCV's hue: 0..179


@numba.njit(cache=True, nogil=True)
def _hsv_bins(hsv: np.ndarray) -> np.ndarray:
    """:func:`colour_bins` of an ``(H, W, 3) uint8`` HSV image, in one pass."""
    height, width = hsv.shape[:2]
    out = np.empty((height, width), dtype=np.uint8)
    for v in range(height):
        for u in range(width):
            hue, saturation, value = np.int32(hsv[v, u, 0]), np.int32(hsv[v, u, 1]), np.int32(hsv[v, u, 2])
            if saturation >= MIN_SATURATION and value >= MIN_VALUE:
                out[v, u] = hue * HUE_BINS // 180 * SATURATION_BINS + saturation * SATURATION_BINS // 256
            else:
                out[v, u] = HUE_BINS * SATURATION_BINS + value * VALUE_BINS // 256
    return out


def bhattacharyya_distance(p: np.ndarray, q: np.ndarray) -> float:
    """``sqrt(1 - Σ sqrt(p q))`` of two normalised histograms (0: identical, 1: disjoint)."""
    return float(np.sqrt(max(0.0, 1.0 - float(np.sum(np.sqrt(p * q))))))


@lru_cache(maxsize=8)
def _grid(parts: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sample offsets ``(G², 2)`` in a unit box centred on 0, their kernel weights and band (read-only)."""
    ticks = (np.arange(GRID) + 0.5) / GRID - 0.5
    u, v = np.meshgrid(ticks, ticks)
    offsets = np.column_stack([u.ravel(), v.ravel()])
    kernel = 1.0 - (2.0 * offsets[:, 0]) ** 2 - (2.0 * offsets[:, 1]) ** 2 / 2.0  # Epanechnikov, flatter in v
    band = np.minimum(((offsets[:, 1] + 0.5) * parts).astype(np.int64), parts - 1)
    grid = (offsets, np.clip(kernel, 0.05, None), band)
    for array in grid:
        array.flags.writeable = False
    return grid


@numba.njit(cache=True, nogil=True, inline='always')
def _accumulate(
    bins: np.ndarray,
    box: np.ndarray,
    angle: float,
    offsets: np.ndarray,
    kernel: np.ndarray,
    band: np.ndarray,
    out: np.ndarray,
) -> None:
    """``out`` ``(parts, num_bins)``: the normalised histograms of one rotated box (cx, cy, w, h)."""
    height, width = bins.shape
    c = np.cos(angle)
    s = np.sin(angle)
    for k in range(offsets.shape[0]):
        du = offsets[k, 0] * box[2]
        dv = offsets[k, 1] * box[3]
        u = int(box[0] + c * du - s * dv)
        v = int(box[1] + s * du + c * dv)
        if 0 <= u < width and 0 <= v < height:
            out[band[k], bins[v, u]] += kernel[k]
    for b in range(out.shape[0]):
        total = out[b].sum()
        if total > 0:
            out[b] /= total


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
    out = np.zeros((boxes.shape[0], parts, num_bins))
    for i in range(boxes.shape[0]):
        _accumulate(bins, boxes[i], angles[i], offsets, kernel, band, out[i])
    return out


@numba.njit(cache=True, nogil=True)
def _squared_distances(
    bins: np.ndarray,
    boxes: np.ndarray,
    angles: np.ndarray,
    offsets: np.ndarray,
    kernel: np.ndarray,
    band: np.ndarray,
    reference: np.ndarray,
) -> np.ndarray:
    """Mean over bands of D² = 1 - Σ sqrt(p q) of each box's histograms from ``reference``; a
    band with no sample in the image counts 1. One histogram at a time: the (P, parts, bins)
    array of them all took longer to fill than to compare."""
    parts, num_bins = reference.shape
    histogram = np.empty((parts, num_bins))
    out = np.empty(boxes.shape[0])
    for i in range(boxes.shape[0]):
        histogram[:] = 0.0
        _accumulate(bins, boxes[i], angles[i], offsets, kernel, band, histogram)
        total = 0.0
        for b in range(parts):
            coefficient = 0.0
            for u in range(num_bins):
                if histogram[b, u] > 0.0:
                    coefficient += np.sqrt(histogram[b, u] * reference[b, u])
            total += max(0.0, 1.0 - coefficient)
        out[i] = total / parts
    return out


def _region_boxes(states: np.ndarray, region: BoxRelation) -> tuple[np.ndarray, np.ndarray]:
    """The region's rotated boxes (cx, cy, w, h) ``(P, 4)`` on the contours at ``states``, and their angles."""
    states = np.atleast_2d(np.asarray(states, dtype=np.float64))
    x, y, s, theta = states.T
    c, sn = np.cos(theta), np.sin(theta)
    u, v = region.centre
    width, height = region.size
    boxes = np.column_stack([x + s * (c * u - sn * v), y + s * (sn * u + c * v), s * width, s * height])
    return boxes, np.ascontiguousarray(theta)


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
    boxes, angles = _region_boxes(states, region)
    offsets, kernel, band = _grid(parts)
    return _histograms(bins, boxes, angles, offsets, kernel, band, parts, NUM_BINS)


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
        boxes, angles = _region_boxes(states, self.region)
        offsets, kernel, band = _grid(self.parts)
        return _squared_distances(bins, boxes, angles, offsets, kernel, band, self.reference)

    def distance_beside(self, bins: np.ndarray, state: np.ndarray, reach: int = 2) -> float:
        """The smallest distance D from the reference of the region on contours beside the one at
        ``state`` [x, y, s, θ] (pixels of ``bins``): moved by whole widths s of the head, up to
        ``reach`` of them across and one up and down, of the same size and turn. Small when the
        target's colours are still in view beside the contour: the contour has left them."""
        steps = np.array([(u, v) for u in range(-reach, reach + 1) for v in (-1, 0, 1) if (u, v) != (0, 0)], float)
        s, theta = float(state[2]), float(state[3])
        c, sn = np.cos(theta), np.sin(theta)
        states = np.tile(np.asarray(state[:4], dtype=np.float64), (len(steps), 1))
        states[:, :2] += s * steps @ np.array([[c, sn], [-sn, c]])  # the steps turned with the contour
        return float(np.sqrt(self.squared_distances(bins, states).min()))

    def adapt(self, bins: np.ndarray, state: np.ndarray, rate: float) -> None:
        """Blend the histograms at ``state`` into the reference: q ← (1 - rate) q + rate p."""
        current = region_histograms(bins, state, self.region, self.parts)[0]
        seen = current.sum(axis=1) > 0
        self.reference[seen] = (1.0 - rate) * self.reference[seen] + rate * current[seen]
