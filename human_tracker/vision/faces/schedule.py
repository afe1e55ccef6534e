"""When and where a target's face detector runs, and the faces it delivers.

A head's faces are its proposals (:mod:`~human_tracker.vision.filter.proposals`): near the predicted
face while the head is followed, on the whole frame while it is not. A hand's faces are what
it keeps off (``avoid_faces``): around the last face found, then on the whole frame. The
detector runs every ``detect_every`` frames, and ``patient_every`` frames apart once
:data:`PATIENT_SEARCHES` runs in a row found no face (a robot often sees a person from behind).
With ``detector_thread`` a run goes on in its own thread while the next frame arrives, and its
faces are delivered on that frame, carried to where the filter predicts them
(:func:`carry_faces`); a frame that comes late (``detector_wait_interval``) waits for its own.
Everything here is in working pixels.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from human_tracker.vision.faces.detector import Detection, FaceDetector, face_detector_available
from human_tracker.vision.faces.finder import SMALLEST_FACE_IN_FRAME, FaceFinder, Found
from human_tracker.vision.faces.parameters import FaceParameters
from human_tracker.vision.filter.dynamics import move_states
from human_tracker.vision.geometry.boxes import Box

__all__ = [
    'PATIENT_SEARCHES',
    'SEARCH_AFTER_MISSES',
    'SEARCH_REACH',
    'FaceSchedule',
    'carry_faces',
]

SEARCH_AFTER_MISSES = 3
"""Detector runs near the track in a row that found no face on it before one searches the whole frame."""
SEARCH_REACH = 4.0
"""A face last seen smaller than :data:`SMALLEST_FACE_IN_FRAME` is looked for within this many of its sizes."""
AVOIDED_FACE_REACH = 2.0
"""A hand looks for the face it keeps off within this many of its sizes of where it was found last."""
PATIENT_SEARCHES = 8
"""Runs in a row without a face after which the detector runs at most every ``patient_every`` frames."""


@dataclass
class FaceSchedule:
    """A target's face searches (on a detector it may share), their schedule and what they found.

    Attributes:
        finder: The detector's searches (:mod:`~human_tracker.vision.faces.finder`), shared by
            the targets of a person tracker; None when the target wants none or dlib is missing.
        frames: Frames scheduled so far (since the last reset).
        searched_on: The frame of the last run.
        faceless_runs: Runs in a row that found no face.
        face_misses: Runs in a row that found no face on the target (a head), or that found no
            face at all (a hand keeping off one).
        last_face: The last face found (x, y, w, h), a hand's to keep off; None.
        detected_on: The grey frame of the last run delivered (a face is localised on it).
        late: Whether the faces delivered on this frame were found on the frame before.
        small_faces: Whether a head that has not found its own face looks for faces too
            small for the whole-frame search too, on every ``patient_every``-th frame
            (:meth:`~human_tracker.vision.faces.finder.FaceFinder.whole`).
    """

    finder: FaceFinder | None = None
    small_faces: bool = False
    frames: int = 0
    searched_on: int = 0
    faceless_runs: int = 0
    face_misses: int = 0
    last_face: Box | None = None
    detected_on: np.ndarray | None = field(default=None, repr=False)
    late: bool = False
    _pending: Found | None = field(default=None, repr=False)
    _stamp_ns: int | None = None

    @classmethod
    def for_target(cls, parameters: FaceParameters, finder: FaceFinder | None = None) -> FaceSchedule:
        """The schedule of a target with ``parameters``: on ``finder`` (a detector of its own,
        and its thread, when None) when it wants faces and dlib is there."""
        if not (parameters.wants_faces and face_detector_available()):
            return cls()
        return cls(finder or FaceFinder(FaceDetector(), parameters.detector_thread))

    @property
    def detector(self) -> FaceDetector | None:
        """The detector, None when the target wants none or dlib is missing."""
        return None if self.finder is None else self.finder.detector

    def reset(self) -> None:
        """Forget what was found; the schedule starts again."""
        self.frames = self.searched_on = self.faceless_runs = self.face_misses = 0
        self.last_face = self.detected_on = self._pending = self._stamp_ns = None

    def drop_pending(self) -> None:
        """Forget the run in flight: its faces belong to a frame before a new start or size."""
        self._pending = None

    def rescale(self, ratio: float) -> None:
        """The working frame's size changed by ``ratio``: no localisation or delivery across it."""
        if self.last_face is not None:
            self.last_face = tuple(v * ratio for v in self.last_face)  # type: ignore[assignment]
        self.detected_on = self._pending = None

    def hand_over(self, face: Box) -> None:
        """This frame's face (a hand's to keep off) where another target places it: no run."""
        self.last_face, self.face_misses = face, 0
        self._pending = None

    def waits(self, stamp_ns: int | None, parameters: FaceParameters) -> bool:
        """Whether this frame's run serves this frame: without a thread, or when the frame comes
        more than ``detector_wait_interval`` after the one before (whose stamp it keeps: the
        next frame is timed from this one)."""
        last, self._stamp_ns = self._stamp_ns, stamp_ns
        if self.finder is None or not self.finder.threaded:
            return True
        if stamp_ns is None or last is None or stamp_ns <= last:
            return False
        return (stamp_ns - last) * 1e-9 > parameters.detector_wait_interval

    def detect(
        self,
        image: np.ndarray,
        waits: bool,
        parameters: FaceParameters,
        predicted: Callable[[int], Box | None],
        carry: Callable[[list[Detection]], list[Detection]],
    ) -> list[Detection] | None:
        """Faces for this working frame, None when no run delivers any on it.

        Args:
            image: The working image (grey or BGR).
            waits: This frame waits for its own run (:meth:`waits`).
            parameters: The target's.
            predicted: Given the runs without a face on the target it tolerates, the face box
                (x, y, w, h) around which a head's detector looks, or None: the whole frame.
            carry: Takes faces found on the frame before to where this frame's prediction puts
                them (:func:`carry_faces`).
        """
        self.frames += 1
        delivered = None
        if self._pending is not None:
            pending, self._pending = self._pending, None
            delivered = carry(self._found(pending, parameters))
        search = self._search(image, parameters, predicted)
        self.late = delivered is not None
        if search is None:
            return delivered
        if waits:
            self.late = False
            return self._found(search, parameters)
        self._pending = search
        return delivered

    def due(self, parameters: FaceParameters, frame: int | None = None) -> bool:
        """Whether a run is due on the ``frame``-th frame scheduled (the next when None)."""
        frame = self.frames + 1 if frame is None else frame
        if self.finder is None or (frame - 1) % parameters.detect_every:
            return False
        return self.faceless_runs < PATIENT_SEARCHES or frame - self.searched_on >= parameters.patient_every

    def localise(self, box: Box) -> Box:
        """``box``, a face found by the last run, found again precisely on its frame."""
        assert self.finder is not None and self.detected_on is not None
        return self.finder.localise(self.detected_on, box)

    def _search(
        self, image: np.ndarray, parameters: FaceParameters, predicted: Callable[[int], Box | None]
    ) -> Found | None:
        """The detector's search on this frame, if one is due."""
        if not self.due(parameters, self.frames):
            return None
        assert self.finder is not None
        self.faceless_runs += 1
        self.searched_on = self.frames
        if parameters.proposals == 'faces':
            return self._head_search(image, parameters, predicted)
        return self._avoided_search(image)

    def _found(self, search: Found, parameters: FaceParameters) -> list[Detection]:
        """Take a search's faces into the bookkeeping."""
        found = search.result()
        self.detected_on = search.grey
        if found:
            self.faceless_runs = 0
        if parameters.avoid_faces:
            if found:
                self.last_face, self.face_misses = found[0].box, 0
            else:
                if self.face_misses >= SEARCH_AFTER_MISSES:
                    self.last_face = None
                self.face_misses += 1
        return found

    def _head_search(
        self, image: np.ndarray, parameters: FaceParameters, predicted: Callable[[int], Box | None]
    ) -> Found:
        """A head's search: near the predicted face while the head is followed and its face was
        found lately; else on the whole frame (for faces too small for it, see ``small_faces``),
        or, for a face last seen too small for that, around where it was."""
        assert self.finder is not None
        face = predicted(self.face_misses)
        if face is not None:
            return self.finder.near(image, face, parameters.face_search_reach)
        self.face_misses = 0
        if self.last_face is not None and self.last_face[2] < SMALLEST_FACE_IN_FRAME:
            return self.finder.near(image, self.last_face, SEARCH_REACH)
        small = self.small_faces and self.last_face is None and self.frames % parameters.patient_every == 0
        return self.finder.whole(image, small)

    def _avoided_search(self, image: np.ndarray) -> Found:
        """A hand's search: around the last face found for ``SEARCH_AFTER_MISSES`` runs (the
        hand may hide it for a while), then on the whole frame."""
        assert self.finder is not None
        if self.last_face is not None and self.face_misses < SEARCH_AFTER_MISSES:
            return self.finder.near(image, self.last_face, AVOIDED_FACE_REACH)
        return self.finder.whole(image)


def carry_faces(
    faces: list[Detection],
    particles: np.ndarray | None,
    previous: np.ndarray | None,
    velocity_damping: float,
    camera_motion: np.ndarray | None,
) -> list[Detection]:
    """Faces found on the frame before, carried to where this frame's prediction puts them: by
    the camera's motion since then (``(2, 3)``, working pixels) and the target's predicted
    displacement (the mean of the AR(2) prediction of the ``(P, 4)`` particles from their
    ``previous`` states). Without it a box re-anchored on a face lags a walking person by a frame."""
    if not faces or particles is None or previous is None:
        return faces
    velocity = velocity_damping * (particles[:, :2] - previous[:, :2]).mean(axis=0)
    centres = np.array([[x + w / 2, y + h / 2, w, 0.0] for x, y, w, h in (face.box for face in faces)])
    moved = centres if camera_motion is None else move_states(centres, camera_motion)
    carried = []
    for face, (dx, dy) in zip(faces, (moved[:, :2] + velocity - centres[:, :2]).tolist(), strict=True):
        x, y, w, h = face.box
        carried.append(face._replace(box=(x + dx, y + dy, w, h), carried=(dx, dy)))
    return carried
