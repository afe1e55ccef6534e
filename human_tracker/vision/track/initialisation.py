"""Initial state X_0 from the moving region (§2.5).

- :func:`state_from_moments` (§2.5.1, after background subtraction): the blob's centroid
  gives (x, y), the direction of its principal axis gives θ, and its width across that axis
  gives the scale.
- :func:`state_from_scan` (§2.5.2, after optical flow, for the head): scan the mask from the
  top for the first moving row (the top of the head), take the scale from the first local
  maximum of the row widths going down (the head's width, before the neck narrows), and
  place the template so its reference region hangs from that top row; θ = θ_upright. Row
  widths are extents (leftmost to rightmost moving pixel).
- :func:`upper_end_state` (a departure, for a hand once it has been found): the moments of
  the upper end of a blob that is a hand with its forearm.

The particle cloud is then drawn from N(X_0, Σ) by the tracker (``initial_spread``).
"""

from __future__ import annotations

import cv2
import numpy as np

from human_tracker.vision.filter.templates import ContourTemplate

__all__ = [
    'blobs',
    'first_local_maximum',
    'largest_blob',
    'moments_state',
    'state_from_moments',
    'state_from_scan',
    'upper_end_state',
]


def blobs(mask: np.ndarray, min_area: int = 1, limit: int = 1) -> list[np.ndarray]:
    """The ``limit`` largest 8-connected regions of ``min_area`` pixels or more, largest first.

    Returns:
        Boolean images, one per region (empty when there is none).
    """
    binary = (mask > 0).astype(np.uint8)
    # 16-bit labels take half the time; a mask has at most one 8-connected region per 2x2 cell.
    cells = ((binary.shape[0] + 1) // 2) * ((binary.shape[1] + 1) // 2)
    label_type = cv2.CV_16U if cells < np.iinfo(np.uint16).max else cv2.CV_32S
    count, labels, stats, _ = cv2.connectedComponentsWithStats(binary, connectivity=8, ltype=label_type)
    areas = stats[1:, cv2.CC_STAT_AREA]
    order = [int(i) for i in np.argsort(-areas, kind='stable')[:limit] if areas[i] >= min_area]
    return [labels == i + 1 for i in order]


def largest_blob(mask: np.ndarray, min_area: int = 1) -> np.ndarray | None:
    """The largest 8-connected region of a binary mask as a boolean image, or None if none."""
    found = blobs(mask, min_area)
    return found[0] if found else None


def _axes(mask: np.ndarray) -> tuple[float, float, np.ndarray, float, float]:
    """Centroid (x, y), major axis (unit vector pointing down the image), and the full width
    and length ``4 sqrt(λ)`` (those of a uniform ellipse) of a ``uint8`` blob mask."""
    # On the blob's bounding box: a tenth of the whole frame's time.
    left, top, width, height = cv2.boundingRect(mask)
    moments = cv2.moments(mask[top : top + height, left : left + width], binaryImage=True)
    area = moments['m00']
    cx, cy = left + moments['m10'] / area, top + moments['m01'] / area
    # The sample covariance of the pixel coordinates (normalised by N - 1, as numpy's cov).
    covariance = np.array([[moments['mu20'], moments['mu11']], [moments['mu11'], moments['mu02']]]) / max(area - 1, 1)
    eigenvalues, eigenvectors = np.linalg.eigh(covariance)
    major = eigenvectors[:, 1]
    if major[1] < 0:  # orient the major axis downwards so θ is near 0 for an upright blob
        major = -major
    width, length = (4.0 * np.sqrt(max(value, 1e-12)) for value in eigenvalues)
    return cx, cy, major, width, length


def moments_state(blob: np.ndarray, template: ContourTemplate) -> np.ndarray:
    """X_0 = [x, y, s, θ] from the inertial moments of one blob (§2.5.1).

    The blob is taken as the template's reference region (a hand, or a head alone): its
    centroid is the region's centre, θ the angle of its major axis from the image vertical,
    and its width ``4 sqrt(λ_minor)`` (the full width of a uniform ellipse) over the region's
    width in template units gives s.
    """
    cx, cy, major, width, _ = _axes(blob.view(np.uint8))
    theta = float(np.arctan2(-major[0], major[1]))
    rx, ry, rw, rh = template.reference_box
    scale = width / rw
    # The reference region's centre sits at template offset (rx + rw/2, ry + rh/2).
    centre = np.array([rx + rw / 2, ry + rh / 2]) * scale
    c, s = np.cos(theta), np.sin(theta)
    offset = np.array([c * centre[0] - s * centre[1], s * centre[0] + c * centre[1]])
    return np.array([cx - offset[0], cy - offset[1], scale, theta])


def upper_end_state(
    blob: np.ndarray, template: ContourTemplate, elongation: float = 2.0, end_widths: float = 1.3
) -> np.ndarray | None:
    """X_0 from the upper end of an elongated blob: a hand with its forearm.

    A blob at least ``elongation`` times as long as wide is cut ``end_widths`` of its widths
    from its upper end, along its major axis, and X_0 is that end's :func:`moments_state`;
    None for a blob less elongated (a hand alone: its own moments). The hand is at the
    forearm's upper end when it is raised or held before the body; the moments of the
    whole blob put X_0 on the forearm.
    """
    mask = blob.view(np.uint8)
    # On the blob's bounding box, as the moments; the state moves back by its corner.
    left, top, w, h = cv2.boundingRect(mask)
    crop = mask[top : top + h, left : left + w]
    cx, cy, major, width, length = _axes(crop)
    if length < elongation * width:
        return None
    rows, cols = np.nonzero(crop)
    along = (cols - cx) * major[0] + (rows - cy) * major[1]
    keep = along <= along.min() + end_widths * width
    end = np.zeros_like(crop)
    end[rows[keep], cols[keep]] = 1
    return moments_state(end, template) + np.array([left, top, 0.0, 0.0])


def state_from_moments(mask: np.ndarray, template: ContourTemplate, min_area: int = 50) -> np.ndarray | None:
    """X_0 from the moments of the largest blob of ``mask`` (§2.5.1), None without a blob of ``min_area`` pixels."""
    blob = largest_blob(mask, min_area)
    return None if blob is None else moments_state(blob, template)


def first_local_maximum(values: np.ndarray) -> int | None:
    """Index of the first local maximum of a sequence (a plateau counts at its start).

    A maximum must be followed by a strict decrease; a sequence that only grows has none.
    """
    values = np.asarray(values, dtype=np.float64)
    start = 0  # first index of the current rise's top (a plateau counts from its start)
    for i in range(1, len(values)):
        if values[i] > values[i - 1]:
            start = i
        elif values[i] < values[i - 1]:
            return start
    return None


def state_from_scan(
    mask: np.ndarray,
    template: ContourTemplate,
    *,
    upright_angle: float = 0.0,
    min_row_pixels: int = 3,
    smoothing: int = 5,
    min_area: int = 50,
) -> np.ndarray | None:
    """X_0 = [x, y, s, θ_upright] by scanning the moving region from the top (§2.5.2).

    Args:
        mask: ``(H, W)`` motion or foreground mask (non-zero: moving).
        template: The head template (its reference region is the head).
        upright_angle: θ_upright, radians.
        min_row_pixels: A row with fewer moving pixels is noise, not the top of the head.
        smoothing: Rows averaged (moving mean) before looking for the width maximum.
        min_area: Smallest blob, pixels, taken as a person.

    Returns:
        The state, or None when nothing moves or no width maximum is found.
    """
    blob = largest_blob(mask, min_area)
    if blob is None:
        return None
    # Row width as the extent from the leftmost to the rightmost moving pixel: a flow mask
    # holds the textured parts of the silhouette, not always its flat interior.
    has = blob.any(axis=1)
    first = np.argmax(blob, axis=1)
    last = blob.shape[1] - 1 - np.argmax(blob[:, ::-1], axis=1)
    widths = np.where(has, last - first + 1, 0).astype(np.float64)
    rows = np.nonzero(widths >= min_row_pixels)[0]
    if rows.size == 0:
        return None
    top = int(rows[0])
    profile = widths[top:]
    if smoothing > 1:
        profile = np.convolve(profile, np.ones(smoothing) / smoothing, mode='same')
    peak = first_local_maximum(profile)
    if peak is None:
        return None
    head_width = float(profile[peak])
    row = top + peak
    centre_x = 0.5 * float(first[row] + last[row]) if has[row] else 0.5 * float(first[top] + last[top])
    rx, ry, rw, rh = template.reference_box
    scale = head_width / rw
    # The reference region's top edge (template y = ry) is the first moving row.
    return np.array([centre_x - scale * (rx + rw / 2), top - scale * ry, scale, upright_angle])
