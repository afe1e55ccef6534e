"""Phase 2 of §3.2: the local clusters of a region (the modes of its I1, I2, I3 histograms),
their (I2, I3) statistics, and the split of a mixed cluster in two."""

from __future__ import annotations

import numba
import numpy as np


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
