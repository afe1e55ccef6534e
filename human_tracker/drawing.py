"""Annotated frames for people: the fitted contour, the particle cloud, boxes and a label."""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

__all__ = ['annotate', 'draw_target', 'id_colour']

_CONTOUR = (0, 255, 0)
_BOX = (0, 200, 255)
_TRUTH = (255, 0, 255)
_PARTICLE = (255, 200, 0)
_DETECTION = (0, 255, 255)
# One colour per target id (BGR), cycled: far apart in hue, none of them the truth's magenta.
_ID_COLOURS = ((0, 255, 0), (255, 128, 0), (0, 128, 255), (255, 255, 0), (128, 0, 255), (0, 255, 255))


def _rect(image: np.ndarray, box: tuple[float, float, float, float], colour: tuple[int, int, int]) -> None:
    x, y, w, h = (int(round(v)) for v in box)
    cv2.rectangle(image, (x, y), (x + w, y + h), colour, 1, cv2.LINE_AA)


def annotate(
    image: np.ndarray,
    *,
    contour: np.ndarray | None = None,
    box: tuple[float, float, float, float] | None = None,
    particles: np.ndarray | None = None,
    truth: tuple[float, float, float, float] | None = None,
    label: str = '',
    closed: bool = False,
    motion: np.ndarray | None = None,
    detections: Sequence[tuple[float, float, float, float]] = (),
) -> np.ndarray:
    """Return a copy of ``image`` (BGR) with the tracker's output drawn on it.

    Args:
        image: ``(H, W, 3) uint8`` BGR frame (mono is converted).
        contour: ``(N, 2)`` fitted contour, pixels (green).
        box: Reference-region box (x, y, w, h) of the estimate, pixels (orange).
        particles: ``(P, >=2)`` particle states; their x, y are drawn as dots (cyan).
        truth: Ground-truth box, pixels (magenta).
        label: Text written in the top-left corner.
        closed: Draw the contour as a closed curve.
        motion: Motion cue (foreground or moving pixels) at any size, tinted red.
        detections: Detector boxes (x, y, w, h), pixels (yellow).
    """
    out = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR) if image.ndim == 2 else image.copy()
    if motion is not None:
        # A cue may come at the working resolution: shown at the frame's.
        size = (out.shape[1], out.shape[0])
        moving = cv2.resize(motion, size, interpolation=cv2.INTER_NEAREST) > 0
        out[moving] = (0.6 * out[moving] + (0, 0, 100)).astype(np.uint8)
    if particles is not None:
        for x, y in np.round(particles[:, :2]).astype(np.int32):
            cv2.circle(out, (int(x), int(y)), 1, _PARTICLE, -1)
    for detection in detections:
        _rect(out, detection, _DETECTION)
    if truth is not None:
        _rect(out, truth, _TRUTH)
    if box is not None:
        _rect(out, box, _BOX)
    if contour is not None:
        cv2.polylines(out, [np.round(contour).astype(np.int32)], closed, _CONTOUR, 2, cv2.LINE_AA)
    if label:
        # White on a dark band: a thick dark copy of the text would advance further per glyph
        # than the thin white one and show as a shifted shadow.
        (width, height), baseline = cv2.getTextSize(label, cv2.FONT_HERSHEY_SIMPLEX, 0.55, 1)
        cv2.rectangle(out, (4, 20 - height - 4), (12 + width, 20 + baseline + 2), (0, 0, 0), -1)
        cv2.putText(out, label, (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (255, 255, 255), 1, cv2.LINE_AA)
    return out


def id_colour(target_id: int) -> tuple[int, int, int]:
    """The BGR colour target ``target_id`` is drawn in (grey for 0: no id)."""
    return (160, 160, 160) if target_id <= 0 else _ID_COLOURS[(target_id - 1) % len(_ID_COLOURS)]


def draw_target(
    image: np.ndarray,
    target_id: int,
    tag: str,
    contour: np.ndarray | None = None,
    box: tuple[float, float, float, float] | None = None,
) -> None:
    """Draw one of several targets on ``image`` (BGR, in place) in its id's colour: its contour,
    its box and ``tag`` (e.g. ``head 3``) above the box."""
    colour = id_colour(target_id)
    if contour is not None:
        cv2.polylines(image, [np.round(contour).astype(np.int32)], False, colour, 2, cv2.LINE_AA)
    if box is not None:
        _rect(image, box, colour)
        x, y = int(round(box[0])), int(round(box[1]))
        cv2.putText(image, tag, (x, max(10, y - 3)), cv2.FONT_HERSHEY_SIMPLEX, 0.4, colour, 1, cv2.LINE_AA)
