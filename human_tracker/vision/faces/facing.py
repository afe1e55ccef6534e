"""Where a followed head faces: toward the camera, to one side, away, or unknown.

The silhouette of head and shoulders is the same from every side (the paper's point); the face
detector is what tells the sides apart. dlib's HOG face detector is five linear filters: a face
looking at the camera, looking to its left, looking to its right, and the first turned in the
image plane either way (:attr:`~human_tracker.vision.faces.detector.Detection.view`). So a detector run
that finds a face on the head says whether it looks toward the camera or to a side; a run that
looks where the face would be and finds none says the head is turned away, when a face there
would be big and bright enough to be found (:func:`size_known`: a contour held at the filter's
smallest scale may stand for a smaller head) and that place no longer looks as the face did where
runs found it turned toward the camera (:class:`FaceLook`: a grey, low-contrast or blurred face
is missed while it is there); otherwise, and while the head is not followed, the facing is
unknown. A single run misses a face now and then (a blink of motion blur, a tilt past
the turned filters), so the facing reported is the verdict most of the last
:data:`VOTING_RUNS` runs gave (:class:`FacingVotes`); between runs it holds.
"""

from __future__ import annotations

from collections import Counter, deque
from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np

from human_tracker.vision.cues.appearance import AppearanceModel
from human_tracker.vision.faces.detector import FACE_ON_HEAD, Detection
from human_tracker.vision.geometry.boxes import Box, BoxRelation

__all__ = [
    'FAINTEST_VISIBLE_FACE',
    'LOOK_MEMORY',
    'SIDE_VIEWS',
    'SMALLEST_SCALE_MARGIN',
    'SMALLEST_VISIBLE_FACE',
    'VOTING_RUNS',
    'FaceLook',
    'Facing',
    'FacingVotes',
    'face_visible',
    'facing_after_run',
    'size_known',
]

SIDE_VIEWS = frozenset({1, 2})
"""dlib's filters for a face looking to its left and to its right (0: toward the camera; 3, 4:
toward the camera, turned in the image plane)."""
SMALLEST_VISIBLE_FACE = 16.0
"""Narrower than this (working pixels) a face is too small for a run to find it: no verdict of ``away``."""
SMALLEST_SCALE_MARGIN = 1.1
"""A head whose scale is within this factor of the filter's smallest scale is held there by
the bound (its particles are clipped to it), not measured: its face may be smaller."""
FAINTEST_VISIBLE_FACE = 15.0
"""Grey-level spread (standard deviation, of 255) around the face region under which it is too
dark for a run to find a face there: no verdict of ``away``."""
VOTING_RUNS = 3
"""The detector runs whose verdicts :class:`FacingVotes` weighs."""
LOOK_MEMORY = 10
"""Runs that found the face toward the camera over which :class:`FaceLook` forgets (its
exponential mean's time constant): the light on a face changes as a person moves."""


class Facing(StrEnum):
    """Where a head faces; its value is the word of ``poses.csv``, ``status`` and the markers."""

    TOWARD = 'toward'
    SIDE = 'side'
    AWAY = 'away'
    UNKNOWN = 'unknown'


def size_known(scale: float, smallest_scale: float, faces_found: int) -> bool:
    """Whether a head's contour at ``scale`` says how big its face is: a contour held at the
    filter's ``smallest_scale`` (within :data:`SMALLEST_SCALE_MARGIN`; both pixels per template
    unit) may stand for a smaller head, unless the detector has found faces on this head
    (``faces_found``): then they are of a size it finds."""
    return scale > SMALLEST_SCALE_MARGIN * smallest_scale or faces_found > 0


def face_visible(grey: np.ndarray, face: Box) -> bool:
    """Whether a face at ``face`` (x, y, w, h, pixels of the ``(H, W) uint8`` image ``grey``)
    would be found if it were there: wide enough (:data:`SMALLEST_VISIBLE_FACE`), inside the
    image for at least half its area, and lit: the grey levels of the region twice its size
    around it (the head and what is behind it; dark hair seen from behind is flat, a dark
    scene is flat all round) spread over :data:`FAINTEST_VISIBLE_FACE`."""
    x, y, w, h = face
    height, width = grey.shape[:2]
    inside_w = min(x + w, width) - max(x, 0.0)
    inside_h = min(y + h, height) - max(y, 0.0)
    if w < SMALLEST_VISIBLE_FACE or max(inside_w, 0.0) * max(inside_h, 0.0) < 0.5 * w * h:
        return False
    left, top = max(int(x - w / 2), 0), max(int(y - h / 2), 0)
    around = grey[top : max(int(y + 1.5 * h), top + 1), left : max(int(x + 1.5 * w), left + 1)]
    return float(around.std()) >= FAINTEST_VISIBLE_FACE


def facing_after_run(face: Detection | None, visible: bool, looks_like_face: bool = False) -> Facing | None:
    """The verdict of a detector run that looked at a followed head: the ``face`` it found on the
    head (its filter tells toward from side); else none (None: the run missed a face) where the
    place of the face still ``looks_like_face`` (:meth:`FaceLook.still_there`); else ``away``
    where a face would have been ``visible`` (:func:`face_visible`), else unknown."""
    if face is not None:
        return Facing.SIDE if face.view in SIDE_VIEWS else Facing.TOWARD
    if looks_like_face:
        return None
    return Facing.AWAY if visible else Facing.UNKNOWN


@dataclass
class FaceLook:
    """What a followed head's face looked like where detector runs found it toward the camera:
    the colour histograms (:class:`~human_tracker.vision.cues.appearance.AppearanceModel`) of the
    face's place on the contour (the head's :class:`~human_tracker.vision.faces.anchoring.FacePlace`;
    :data:`~human_tracker.vision.faces.detector.FACE_ON_HEAD` by default), their mean
    over such runs, the last :data:`LOOK_MEMORY` weighing most. The back of a head (hair) and a
    hand or a book before the face do not look like it; a face the detector missed does."""

    model: AppearanceModel | None = None
    runs: int = 0

    def seen(self, bins: np.ndarray, state: np.ndarray, place: BoxRelation = FACE_ON_HEAD) -> None:
        """A run found the face toward the camera on the head at ``state`` (pixels of ``bins``),
        where ``place`` puts the face on the contour."""
        self.runs += 1
        if self.model is None:
            self.model = AppearanceModel.learn(bins, state, place)
        else:
            self.model.region = place  # where the head's face is now known to sit
            self.model.adapt(bins, state, max(1.0 / self.runs, 1.0 / LOOK_MEMORY))

    def still_there(self, bins: np.ndarray, state: np.ndarray, limit: float) -> bool:
        """Whether the face's place on the head at ``state`` lies within the Bhattacharyya
        distance ``limit`` of the face's look (False before a run found the face)."""
        if self.model is None:
            return False
        return float(np.sqrt(self.model.squared_distances(bins, state[None, :4])[0])) <= limit

    def clear(self) -> None:
        """Forget the face: another person, or the track was reset."""
        self.model, self.runs = None, 0


@dataclass
class FacingVotes:
    """The verdicts of a followed head's last :data:`VOTING_RUNS` detector runs, and the facing
    they give: the verdict most of them gave, the latest on a tie; unknown before any run."""

    runs: deque[Facing] = field(default_factory=lambda: deque(maxlen=VOTING_RUNS))

    @property
    def facing(self) -> Facing:
        """Where the head faces now."""
        if not self.runs:
            return Facing.UNKNOWN
        counts = Counter(self.runs)
        return max(reversed(self.runs), key=lambda verdict: counts[verdict])

    def add(self, verdict: Facing) -> None:
        """A run's verdict (:func:`facing_after_run`)."""
        self.runs.append(verdict)

    def clear(self) -> None:
        """Forget the runs: the head is not followed."""
        self.runs.clear()
