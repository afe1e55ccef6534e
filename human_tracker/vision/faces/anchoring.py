"""Faces on a followed head: which face is the head's, when a face restarts the track, and
where the reported box sits.

The box a track reports is a region of its contour (:class:`~human_tracker.vision.geometry.boxes.BoxRelation`).
The contour of a head and shoulders does not say where the face is within it as the head turns;
a face found on the head does. The first one records how the reported box sits on the face
(:attr:`BoxAnchor.face_relation`, in units of the face's width); each later one moves the box
there, and the contour carries it until the next. Everything here is in working pixels.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from human_tracker.vision.faces.detector import FACE_ON_HEAD, Detection
from human_tracker.vision.filter.contour_filter import Appearance, TrackEstimate
from human_tracker.vision.geometry.boxes import Box, BoxRelation, box_centre

__all__ = [
    'FACE_BESIDE',
    'FACE_MATCH_DISTANCE',
    'FACE_MATCH_SIZE',
    'FACE_SIZE_CHANGE',
    'FRESH_FACE_FRAMES',
    'UNCONFIRMED_FRAMES',
    'BoxAnchor',
    'FacePlace',
    'could_be_own_face',
    'could_be_own_faces',
    'face_and_neck',
    'face_beside',
    'face_on',
    'restart_on_face',
    'same_face',
]

FACE_MATCH_DISTANCE = 0.75
"""A face belongs to the head when its centre is within this many face widths of where the
contour puts the face, ..."""
FACE_MATCH_SIZE = 1.75
"""... and its size within this factor of that face's: a contour shrinking onto the face or
the hair must still find its face."""
FRESH_FACE_FRAMES = 4
"""A head's own face is fresh while it was found within this many frames."""
FACE_BESIDE = 1.2
"""A face of the head's size (within ``FACE_SIZE_CHANGE``) whose head lies within this many head
widths of the contour's, not on it: the contour slid off the person beside it."""
UNCONFIRMED_FRAMES = 30
"""A head started from a box whose own face was not found for this many frames is unconfirmed:
it holds less firmly against a face found elsewhere (:func:`restart_on_face`)."""
FACE_SIZE_CHANGE = 1.25
"""A face found away from a head whose face is fresh restarts it only within this factor of
that face's size (or near where it was): another size elsewhere is someone else's face."""


@dataclass
class BoxAnchor:
    """How the reported box sits on the contour, and on the head's face once one was found.

    Attributes:
        box_relation: The reported box on the contour; None: the template's reference region.
        face_relation: The reported box on the face (set by the first face found on the head).
    """

    box_relation: BoxRelation | None = None
    face_relation: BoxRelation | None = None

    def on_face(
        self,
        face: Detection,
        state: np.ndarray,
        *,
        then: np.ndarray | None,
        given_box: Box | None,
        localise: Callable[[Box], Box] | None,
        own_region: BoxRelation,
    ) -> None:
        """Re-anchor the reported box on ``face``, found on the head at ``state``.

        Args:
            face: The face, carried to this frame when found on the one before (``face.carried``).
            state: This frame's estimate.
            then: The state reported on the frame a face delivered a frame late was found on
                (None: found on this frame). Once the relation is known, such a face is placed
                by the mean of two estimates of the head's motion since: the filter's prediction,
                which carried it, and the contour's displacement from ``then`` to ``state``.
            given_box: The box a track was started from on this frame: the first face relates
                to it.
            localise: Finds the face again precisely on its frame (the first face: the relation
                is kept for the whole track and must not carry one detection's jitter); None:
                as found.
            own_region: The template's reference region, the box of a track started by itself.
        """
        (x, y, w, h), (dx, dy) = face.box, face.carried
        if self.face_relation is None and localise is not None:
            x, y, w, h = localise((x - dx, y - dy, w, h))
            x, y = x + dx, y + dy
        if self.face_relation is not None and then is not None:
            moved = BoxRelation.of((x - dx, y - dy, w, h), then).box(state)
            x, y, w, h = (0.5 * (a + b) for a, b in zip((x, y, w, h), moved, strict=True))
        face_state = np.array([x + w / 2, y + h / 2, w, 0.0])
        if self.face_relation is not None:
            self.box_relation = BoxRelation.of(self.face_relation.box(face_state), state)
            return
        if given_box is not None:
            box = given_box
        elif self.box_relation is not None and then is not None:
            # The box reported on the frame the face was found on, carried like the face: the
            # relation of two things seen on one frame.
            bx, by, bw, bh = self.box_relation.box(then)
            box = (bx + dx, by + dy, bw, bh)
        elif self.box_relation is not None:
            box = self.box_relation.box(state)
        else:
            # A track started by itself reports the head box: where the face puts the head.
            box = own_region.box(FACE_ON_HEAD.state((x, y, w, h)))
        self.face_relation = BoxRelation.of(box, face_state)


@dataclass
class FacePlace:
    """Where a head's own face sits on its contour: :data:`~human_tracker.vision.faces.detector.FACE_ON_HEAD`
    until a face is found on it, then the mean relation (:class:`~human_tracker.vision.geometry.boxes.BoxRelation`)
    of every face found on its steady frames.

    The faces' proposals, their detection term, which face is the head's and where its
    detector looks all use it. The generic relation is a face on an average head; on a real
    head the contour the edges fit sits elsewhere around the face (docs/decisions/face-place.md),
    and a face drawing the contour to the generic place pulls it off the edges. A person's face
    does not move on their head, so every face weighs the same: a short memory would follow
    the contour's own errors.
    """

    faces: int = 0
    _centre: np.ndarray = field(default_factory=lambda: np.zeros(2), repr=False)
    _size: np.ndarray = field(default_factory=lambda: np.zeros(2), repr=False)

    @property
    def relation(self) -> BoxRelation:
        """The face's place on the head's contour (template units)."""
        if not self.faces:
            return FACE_ON_HEAD
        centre, size = self._centre / self.faces, self._size / self.faces
        return BoxRelation((float(centre[0]), float(centre[1])), (float(size[0]), float(size[1])))

    def add(self, face: Box, state: np.ndarray) -> None:
        """Take ``face`` (x, y, w, h), found on the head at ``state``, into the mean."""
        relation = BoxRelation.of(face, state)
        self.faces += 1
        self._centre += relation.centre
        self._size += relation.size

    def clear(self) -> None:
        """Forget the faces (a new target)."""
        self.faces = 0
        self._centre, self._size = np.zeros(2), np.zeros(2)


def face_on(detections: list[Detection], state: np.ndarray, place: BoxRelation = FACE_ON_HEAD) -> Detection | None:
    """The nearest of ``detections`` that is the face of the head at ``state``: within
    ``FACE_MATCH_DISTANCE`` face widths of where the contour puts the face (``place``), of
    about its size (within ``FACE_MATCH_SIZE``). The nearest, not the likeliest: a face passing
    close by (someone walking in front) is not this head's."""
    x, y, size, height = place.box(state)
    centre = np.array([x + size / 2, y + height / 2])
    best, best_distance = None, FACE_MATCH_DISTANCE * size
    for detection in detections:
        distance = float(np.hypot(*(np.array(box_centre(detection.box)) - centre)))
        if distance <= best_distance and 1 / FACE_MATCH_SIZE <= detection.box[2] / size <= FACE_MATCH_SIZE:
            best, best_distance = detection, distance
    return best


def restart_on_face(
    states: np.ndarray,
    face: Detection | None,
    estimate: TrackEstimate | None,
    appearance: Appearance | None,
    *,
    holding: bool,
    started_from_box: bool,
    fresh_face: Box | None,
    lost_appearance_distance: float,
    confirmed: bool = True,
    place: BoxRelation = FACE_ON_HEAD,
) -> int | None:
    """Which detection (index into ``states``, the faces' head states, best first) restarts the
    filter, or None.

    The best one when the target is not ``holding`` (not TRACKING, or weak on this frame) or
    has no ``estimate``. None when ``face`` (a detection on the head) was found. A target
    found by itself (not ``started_from_box``) is a head by its face: without it, the first
    detection that could be its own face (:func:`could_be_own_face`). A target started from a
    box, followed without its face: a face of its size beside the contour (:func:`face_beside`:
    the contour slid off the person), or one that looks more like the target than the estimate
    does (a contour that slid onto clutter, or shrank onto part of the head); once it is not
    ``confirmed`` (its own face not found for :data:`UNCONFIRMED_FRAMES` frames), as a target
    found by itself: the absence of its face does not make a head weak, but a contour no face
    has confirmed for a while may hold clutter that fits as well as the head. ``place``: where
    the head's face sits on its contour (:class:`FacePlace`).
    """
    if not holding or estimate is None:
        return 0
    if face is not None:
        return None
    if not started_from_box or not confirmed:
        return could_be_own_face(states, fresh_face, place)
    beside = face_beside(states, estimate.state)
    if beside is not None:
        return beside
    if appearance is None:
        return None
    distances = np.sqrt(appearance(states))
    k = int(np.argmin(distances))
    limit = min(lost_appearance_distance, estimate.appearance_distance)
    return k if distances[k] < limit else None


def _alike_in_size(ratios: np.ndarray | float) -> np.ndarray | bool:
    """Whether sizes ``ratios`` apart (one face's scale over another's) are within a factor
    :data:`FACE_SIZE_CHANGE` of each other: a face does not change size more in a few frames."""
    return (ratios >= 1 / FACE_SIZE_CHANGE) & (ratios <= FACE_SIZE_CHANGE)


def face_beside(states: np.ndarray, state: np.ndarray) -> int | None:
    """Of the faces' head ``states``, the nearest whose head is within :data:`FACE_BESIDE` head
    widths of the contour at ``state`` and of its size (within ``FACE_SIZE_CHANGE``); None."""
    distances = np.hypot(*(states[:, :2] - state[:2]).T) / state[2]
    beside = _alike_in_size(states[:, 2] / state[2]) & (distances <= FACE_BESIDE)
    if not beside.any():
        return None
    return int(np.flatnonzero(beside)[np.argmin(distances[beside])])


def could_be_own_faces(states: np.ndarray, fresh_face: Box, place: BoxRelation = FACE_ON_HEAD) -> np.ndarray:
    """Which of ``states`` (``(D, 4)`` faces' head states) could be the head's own ``fresh_face``
    (found within ``FRESH_FACE_FRAMES`` frames): within a factor ``FACE_SIZE_CHANGE`` of its
    size, or within ``FACE_MATCH_DISTANCE`` of its widths of where it was (a face half out of
    the frame is found at other sizes). A face does not change size that much in a few frames:
    one of another size elsewhere is someone else's, or the detector's mistake while a hand
    hides this one. ``states`` and the fresh face's head are placed by ``place``. Returns a
    ``(D,)`` boolean mask."""
    own = place.state(fresh_face)
    near = np.hypot(*(states[:, :2] - own[:2]).T) <= FACE_MATCH_DISTANCE * fresh_face[2]
    return _alike_in_size(states[:, 2] / own[2]) | near


def could_be_own_face(states: np.ndarray, fresh_face: Box | None, place: BoxRelation = FACE_ON_HEAD) -> int | None:
    """The first of ``states`` (faces' head states, best first) that could be the head's own
    ``fresh_face`` (:func:`could_be_own_faces`); None when none could, the first when there is
    no fresh face."""
    if fresh_face is None:
        return 0
    could = np.flatnonzero(could_be_own_faces(states, fresh_face, place))
    return int(could[0]) if could.size else None


def same_face(state: np.ndarray, other: np.ndarray) -> bool:
    """Whether faces' head states ``state`` and ``other`` (x, y, s, θ) found on two detector runs
    a few frames apart could be one face: within ``FACE_MATCH_DISTANCE`` head widths and a
    factor ``FACE_SIZE_CHANGE`` in size of each other."""
    near = float(np.hypot(*(state[:2] - other[:2]))) <= FACE_MATCH_DISTANCE * other[2]
    return near and bool(_alike_in_size(state[2] / other[2]))


def face_and_neck(face: Box) -> Box:
    """The skin around a detected face box (x, y, w, h): the box runs from the eyebrows to the
    chin, and the forehead above it and the neck and collar down to 1.5 face heights below the
    chin are skin of the same region (docs/decisions/face-and-neck.md)."""
    x, y, w, h = face
    return (x - 0.2 * w, y - 0.3 * h, 1.4 * w, 2.8 * h)
