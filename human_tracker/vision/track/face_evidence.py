"""What a track reads from faces: where its head's face is predicted, which faces found restart
or draw it, where its box is placed by the head's look, and where the head faces.

:class:`TrackFaces` is the :class:`~human_tracker.vision.track.state.Track` with these methods;
:class:`~human_tracker.vision.track.target.TargetTracker` calls them from its stages 2, 4 and 5.
"""

from __future__ import annotations

import numpy as np

from human_tracker.vision.cues.evidence import WorkingFrame
from human_tracker.vision.faces.anchoring import (
    FRESH_FACE_FRAMES,
    UNCONFIRMED_FRAMES,
    could_be_own_faces,
    restart_on_face,
    same_face,
)
from human_tracker.vision.faces.detector import Detection
from human_tracker.vision.faces.facing import Facing, face_visible, facing_after_run, size_known
from human_tracker.vision.faces.schedule import SEARCH_AFTER_MISSES, carry_faces
from human_tracker.vision.filter.contour_filter import Appearance, TrackEstimate
from human_tracker.vision.geometry.boxes import Box
from human_tracker.vision.track.lifecycle import TRACKING
from human_tracker.vision.track.state import Track

__all__ = ['TrackFaces']


class TrackFaces(Track):
    """A track's reading of the faces found (its state is :class:`Track`'s)."""

    def _drawing(self, states: np.ndarray | None) -> np.ndarray | None:
        """Of the proposals' ``states``, those that draw particles and centre the detection term.
        While a head holds (TRACKING, not weak) with its own face fresh, only the faces that could
        be that one (:func:`~.anchoring.could_be_own_faces`): another person's face near by is no
        evidence of this head, and particles drawn onto that person's head and shoulders, which
        fit as well, would carry the filter there."""
        fresh = self._fresh_face()
        holding = self.status == TRACKING and self.weak_frames == 0
        if states is None or self.parameters.proposals != 'faces' or fresh is None or not holding:
            return states
        own = states[could_be_own_faces(states, fresh, self.face_place.relation)]
        return own if len(own) else None

    def _restart_on_face(
        self, states: np.ndarray, face: Detection | None, estimate: TrackEstimate | None, appearance: Appearance | None
    ) -> int | None:
        """Which of the faces' ``states`` restarts the filter (:func:`~.anchoring.restart_on_face`).
        A face that takes a holding head found by itself, its own face fresh, off its contour
        must be found on two runs in a row (:func:`~.anchoring.same_face`, within
        ``FRESH_FACE_FRAMES`` frames): one detection alone may be the detector's mistake on
        clutter beside the face a hand hides."""
        holding, fresh = self.status == TRACKING and self.weak_frames == 0, self._fresh_face()
        k = restart_on_face(
            states,
            face,
            estimate,
            appearance,
            holding=holding,
            started_from_box=self.started_from_box,
            fresh_face=fresh,
            lost_appearance_distance=self.parameters.lost_appearance_distance,
            confirmed=self.frames_without_own_face < UNCONFIRMED_FRAMES,
            place=self.face_place.relation,
        )
        if k is None or not holding or self.started_from_box or fresh is None:
            self.disputing_face = None
            return k
        before, self.disputing_face = self.disputing_face, (states[k], self.faces.frames)
        if before is None or self.faces.frames - before[1] > FRESH_FACE_FRAMES or not same_face(states[k], before[0]):
            return None
        self.disputing_face = None
        return k

    def _predicted_face(self, face_misses: int) -> Box | None:
        """Where a head's detector looks for its face: on the predicted contour (its
        :class:`~.anchoring.FacePlace`) while the head is followed, not weak, and its face was
        missed fewer times than it tolerates (a head found by itself is a head by its face:
        once; one started from a box: ``SEARCH_AFTER_MISSES``); None: search the frame."""
        tracked = self.status == TRACKING and self.filter.particles is not None and self.weak_frames == 0
        patience = SEARCH_AFTER_MISSES if self.started_from_box else 1
        if not tracked or face_misses >= patience:
            return None
        return self.face_place.relation.box(self.filter.particles.mean(axis=0))

    def _carry(self, faces: list[Detection]) -> list[Detection]:
        """Faces found on the frame before, where this frame's prediction puts them."""
        filter = self.filter
        return carry_faces(
            faces, filter.particles, filter.previous, filter.parameters.velocity_damping, self.camera.motion
        )

    def _anchor_on_face(
        self, face: Detection, state: np.ndarray, given_box: Box | None = None, initialised: bool = False
    ) -> None:
        """Re-anchor the reported box on ``face``, found on the head at ``state`` (working pixels):
        :meth:`~human_tracker.vision.faces.anchoring.BoxAnchor.on_face`."""
        then = None if not self.faces.late or initialised or given_box is not None else self.reported_state
        localise = self.faces.localise if self.detector is not None and self.faces.detected_on is not None else None
        self.anchor.on_face(
            face, state, then=then, given_box=given_box, localise=localise, own_region=self._own_region()
        )

    def _vote_facing(self, face: Detection | None, frame: WorkingFrame, state: np.ndarray) -> None:
        """A detector run's verdict of where the head at ``state`` (working pixels) faces; a face
        found toward the camera is what its place on the head looks like (:class:`~.facing.FaceLook`)."""
        bins, place = frame.bins, self.face_place.relation
        verdict = facing_after_run(
            face,
            face is None
            and size_known(float(state[2]), self.filter.parameters.min_scale, self.face_place.faces)
            and face_visible(frame.grey, place.box(state)),
            face is None
            and bins is not None
            and self.face_look.still_there(bins, state, self.parameters.lost_appearance_distance),
        )
        if verdict is Facing.TOWARD and bins is not None:
            self.face_look.seen(bins, state, place)
        if verdict is not None:
            self.facing_votes.add(verdict)

    def _box_by_look(
        self, grey: np.ndarray, state: np.ndarray, face: Detection | None, given_box: Box | None
    ) -> Box | None:
        """A head's box on this frame found by its look (``box_search_reach``,
        :class:`~.box_look.BoxLook`), learnt where the box's place is known: the start box and
        each face that anchors it. None: where the contour places it (working pixels)."""
        p = self.parameters
        if p.box_search_reach <= 0.0 or p.proposals != 'faces' or self.anchor.box_relation is None:
            return None
        box = self.anchor.box_relation.box(state)
        if given_box is not None or (face is not None and self.status == TRACKING) or self.box_look.patch is None:
            self.box_look.learn(grey, box)
            return None
        if self.status != TRACKING:
            return None
        found = self.box_look.find(grey, box, p.box_search_reach, p.box_min_match)
        if found is not None and p.box_look_rate > 0.0:
            self.box_look.learn(grey, found, p.box_look_rate)
        return found
