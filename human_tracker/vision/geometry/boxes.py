"""Reported boxes that keep the meaning of the box a track started from.

A tracking benchmark (or an operator) starts a track from a box: a face box, a head box, a
hand box. The contour settles on the silhouette around it, whose reference region (the
template's head or hand box) need not be that box. The start box is then expressed in the
contour's own frame, in template units, and every later box is that same region of the
fitted contour: a face box stays a face box as the person moves, turns and comes closer.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ['Box', 'BoxRelation', 'box_centre', 'centre_within']

Box = tuple[float, float, float, float]


def box_centre(box: Box) -> tuple[float, float]:
    """The centre (x, y) of a box (x, y, w, h)."""
    return box[0] + box[2] / 2, box[1] + box[3] / 2


def centre_within(box: Box, outer: Box, share: float = 1.0) -> bool:
    """Whether the centre of ``box`` lies inside ``outer`` (both x, y, w, h), or inside the
    central ``share`` of its width and height."""
    x, y = box_centre(box)
    cx, cy = box_centre(outer)
    return abs(x - cx) <= share * outer[2] / 2 and abs(y - cy) <= share * outer[3] / 2


@dataclass(frozen=True)
class BoxRelation:
    """Where a box sits on a contour at state [x, y, s, θ], in template units.

    Attributes:
        centre: ``(2,)`` the box centre in the contour's frame (template units: image offset
            from the state's origin, rotated by −θ, divided by s).
        size: ``(2,)`` the box width and height divided by s.
    """

    centre: tuple[float, float]
    size: tuple[float, float]

    @classmethod
    def of(cls, box: Box, state: np.ndarray) -> BoxRelation:
        """How ``box`` (x, y, w, h, pixels) sits on the contour at ``state`` (pixels)."""
        x, y, w, h = (float(v) for v in box)
        cx, cy, s, theta = (float(v) for v in state[:4])
        dx, dy = x + w / 2 - cx, y + h / 2 - cy
        cos, sin = np.cos(theta), np.sin(theta)
        return cls(((cos * dx + sin * dy) / s, (-sin * dx + cos * dy) / s), (w / s, h / s))

    def box(self, state: np.ndarray) -> Box:
        """The box (x, y, w, h, pixels) that sits the same way on the contour at ``state``."""
        cx, cy, s, theta = (float(v) for v in state[:4])
        u, v = self.centre
        cos, sin = np.cos(theta), np.sin(theta)
        x, y = cx + s * (cos * u - sin * v), cy + s * (sin * u + cos * v)
        w, h = s * self.size[0], s * self.size[1]
        return x - w / 2, y - h / 2, w, h

    def state(self, box: Box, angle: float = 0.0) -> np.ndarray:
        """The state [x, y, s, θ = ``angle``] on whose contour ``box`` (x, y, w, h) sits this way."""
        x, y, w, h = (float(v) for v in box)
        s = 0.5 * (w / self.size[0] + h / self.size[1])
        u, v = self.centre
        cos, sin = np.cos(angle), np.sin(angle)
        return np.array([x + w / 2 - s * (cos * u - sin * v), y + h / 2 - s * (sin * u + cos * v), s, angle])
