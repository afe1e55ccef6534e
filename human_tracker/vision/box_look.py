"""A head's reported box found again by its grey-level look between the faces that anchor it.

The contour carries the reported box rigidly (:class:`~human_tracker.vision.boxes.BoxRelation`).
A head leaning over its shoulders moves around the neck, and the outline the edges fit, head
and shoulders together, does not follow it; until a face is found on it again the box stays
where the shoulders put it (docs/decisions/box-placed-by-the-heads-look.md). The box's grey
levels, learnt where its place is known (the start box, each face that anchors it), are
searched for around the contour's place by normalised cross-correlation; a match places that
frame's box only, the relation stays, so one wrong match costs one frame. Everything here is
in working pixels.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from human_tracker.vision.boxes import Box

__all__ = ['MIN_PATCH_WIDTH', 'BoxLook']

MIN_PATCH_WIDTH = 8
"""Boxes narrower than this (working pixels) have too few pixels to learn a look from."""


@dataclass
class BoxLook:
    """The grey patch of a head's reported box, learnt where the box's place is known.

    Attributes:
        patch: The patch (uint8 grey, the box's own pixels); None until one is learnt.
    """

    patch: np.ndarray | None = field(default=None, repr=False)

    def learn(self, grey: np.ndarray, box: Box) -> None:
        """Learn the look of ``box`` (x, y, w, h) on ``grey``; a box narrower than
        :data:`MIN_PATCH_WIDTH` or not wholly in the frame keeps the patch learnt before."""
        x, y, w, h = box
        x0, y0, x1, y1 = round(x), round(y), round(x + w), round(y + h)
        if w > MIN_PATCH_WIDTH and x0 >= 0 and y0 >= 0 and x1 <= grey.shape[1] and y1 <= grey.shape[0]:
            self.patch = grey[y0:y1, x0:x1].copy()

    def find(self, grey: np.ndarray, box: Box, reach: float, min_match: float) -> Box | None:
        """Where the learnt look is on ``grey`` near ``box`` (x, y, w, h), the box the contour places.

        Args:
            grey: The frame's grey image.
            box: The box where the contour places it; the patch is resized to its size.
            reach: The search extends this many box widths to every side of ``box``.
            min_match: The least normalised cross-correlation (``TM_CCOEFF_NORMED``, in [-1, 1])
                of a match.

        Returns:
            ``box`` moved to the best match, or None: no patch, the search window not wholly
            in the frame, or no match of at least ``min_match``.
        """
        if self.patch is None:
            return None
        x, y, w, h = box
        width, height = max(MIN_PATCH_WIDTH, round(w)), max(MIN_PATCH_WIDTH, round(h))
        margin = round(reach * w)
        x0, y0 = round(x) - margin, round(y) - margin
        x1, y1 = x0 + width + 2 * margin, y0 + height + 2 * margin
        if x0 < 0 or y0 < 0 or x1 > grey.shape[1] or y1 > grey.shape[0]:
            return None
        patch = cv2.resize(self.patch, (width, height), interpolation=cv2.INTER_AREA)
        scores = cv2.matchTemplate(grey[y0:y1, x0:x1], patch, cv2.TM_CCOEFF_NORMED)
        _, best, _, (dx, dy) = cv2.minMaxLoc(scores)
        if best < min_match:
            return None
        return float(x0 + dx), float(y0 + dy), w, h

    def clear(self) -> None:
        """Forget the look (a new target)."""
        self.patch = None
