"""A head's reported box found again by its grey-level look between the faces that anchor it.

The contour carries the reported box rigidly (:class:`~human_tracker.vision.geometry.boxes.BoxRelation`).
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

from human_tracker.vision.geometry.boxes import Box, box_centre

__all__ = ['MIN_PATCH_WIDTH', 'SIZE_STEP', 'BoxLook']

MIN_PATCH_WIDTH = 8
"""Boxes narrower than this (working pixels) have too few pixels to learn a look from."""

SIZE_STEP = 1.25
"""The largest ratio of one size searched to the next."""


def _sizes_between(first: float, last: float) -> np.ndarray:
    """Widths from ``first`` to ``last`` in a geometric progression of steps at most
    :data:`SIZE_STEP`; ``first`` alone when they are within one step."""
    ratio = abs(np.log(last / first)) / np.log(SIZE_STEP)
    return np.geomspace(first, last, int(np.ceil(ratio)) + 1) if ratio > 1.0 else np.array([first])


def _in_frame(grey: np.ndarray, x0: int, y0: int, x1: int, y1: int) -> bool:
    """Whether the window [x0, x1) x [y0, y1) lies wholly in ``grey``."""
    return x0 >= 0 and y0 >= 0 and x1 <= grey.shape[1] and y1 <= grey.shape[0]


@dataclass
class BoxLook:
    """The grey patch of a head's reported box, learnt where the box's place is known.

    Attributes:
        patch: The patch (float32 grey levels, the box's own pixels); None until one is learnt.
    """

    patch: np.ndarray | None = field(default=None, repr=False)

    def learn(self, grey: np.ndarray, box: Box, rate: float = 1.0) -> None:
        """Learn the look of ``box`` (x, y, w, h) on ``grey``: the patch there, or with ``rate``
        below 1 that share of it blended into the patch learnt before (resized to that patch's
        size). A box narrower than :data:`MIN_PATCH_WIDTH` or not wholly in the frame keeps
        the patch learnt before."""
        x, y, w, h = box
        x0, y0, x1, y1 = round(x), round(y), round(x + w), round(y + h)
        if w <= MIN_PATCH_WIDTH or not _in_frame(grey, x0, y0, x1, y1):
            return
        seen = grey[y0:y1, x0:x1].astype(np.float32)
        if self.patch is None or rate >= 1.0:
            self.patch = seen
            return
        seen = cv2.resize(seen, self.patch.shape[::-1], interpolation=cv2.INTER_AREA)
        self.patch = (1.0 - rate) * self.patch + rate * seen

    def find(self, grey: np.ndarray, box: Box, reach: float, min_match: float) -> Box | None:
        """Where the learnt look is on ``grey`` near ``box`` (x, y, w, h), the box the contour places.

        The look is searched at the box's size, at the size it was learnt at and at sizes
        between (steps of at most :data:`SIZE_STEP`): a contour that shrank or grew onto other
        edges carries a box of the wrong size, and the look, not the contour, then says how
        large the head is.

        Args:
            grey: The frame's grey image.
            box: The box where the contour places it; every search is centred on it.
            reach: Each search extends this many widths of the size searched to every side.
            min_match: The least normalised cross-correlation (``TM_CCOEFF_NORMED``, in [-1, 1])
                of a match.

        Returns:
            The best match's box (its size the one searched), or None: no patch, no search
            window wholly in the frame, or no match of at least ``min_match``.
        """
        if self.patch is None:
            return None
        _, _, w, h = box
        centre_x, centre_y = box_centre(box)
        best, found = min_match, None
        for size_w in _sizes_between(w, self.patch.shape[1]):
            size_h = size_w * h / w
            width, height = max(MIN_PATCH_WIDTH, round(size_w)), max(MIN_PATCH_WIDTH, round(size_h))
            margin = round(reach * size_w)
            x0, y0 = round(centre_x - size_w / 2) - margin, round(centre_y - size_h / 2) - margin
            x1, y1 = x0 + width + 2 * margin, y0 + height + 2 * margin
            if not _in_frame(grey, x0, y0, x1, y1):
                continue
            patch = cv2.resize(self.patch, (width, height), interpolation=cv2.INTER_AREA).astype(np.uint8)
            scores = cv2.matchTemplate(grey[y0:y1, x0:x1], patch, cv2.TM_CCOEFF_NORMED)
            _, score, _, (dx, dy) = cv2.minMaxLoc(scores)
            if score >= best:
                best, found = score, (float(x0 + dx), float(y0 + dy), size_w, size_h)
        return found

    def clear(self) -> None:
        """Forget the look (a new target)."""
        self.patch = None
