"""Following one target: the contour filter with its cues, its starts and its loss tests.

Per frame (:meth:`TargetTracker.step`), in five stages:

1. **Observe.** The frame's :class:`~human_tracker.vision.cues.evidence.Evidence` at this track's
   working resolution: edges, colour bins, the motion mask (eqs. 3-4; set aside when it covers
   most of the frame: the camera moved) and the skin labels (§3.2), each in the likelihood or
   as a mask on the edges (:func:`~human_tracker.vision.cues.evidence.working_cues`). The particles
   are carried with the camera's shake.
2. **Propose.** Faces (a head's proposals; what a hand keeps off) from the face schedule
   (:mod:`~human_tracker.vision.faces.schedule`), skin regions (a hand's), and the region X_0
   comes from (§2.5, :mod:`~human_tracker.vision.track.starts`).
3. **Predict, weigh, resample**: the filter's step (§2.2-2.4,
   :class:`~human_tracker.vision.filter.contour_filter.ContourTracker`).
4. **(Re)start.** On a face where the target is not held (:mod:`~human_tracker.vision.faces.anchoring`),
   or on a hypothesis from the region when there is no target or it is clearly better elsewhere.
5. **Verify.** The reported box is anchored (on the start box, on a face); the frame is weak
   or not (:meth:`TargetTracker._weak`), and the state changes only through
   :func:`~human_tracker.vision.track.lifecycle.transition`: LOST after ``lost_frames`` weak frames
   in a row, TRACKING again when a lost target's evidence holds (:meth:`TargetTracker._recovers`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from functools import partial
from typing import NamedTuple

import numpy as np

from human_tracker.vision.cues.appearance import AppearanceModel
from human_tracker.vision.cues.evidence import Cues, Evidence, WorkingFrame, working_cues
from human_tracker.vision.cues.resolution import working_scale
from human_tracker.vision.faces.anchoring import (
    face_and_neck,
    face_on,
)
from human_tracker.vision.faces.detector import Detection
from human_tracker.vision.filter.contour_filter import Appearance, TrackEstimate
from human_tracker.vision.geometry.boxes import Box, BoxRelation, centre_within
from human_tracker.vision.track.face_evidence import TrackFaces
from human_tracker.vision.track.lifecycle import (
    LOST,
    TRACKING,
    Event,
    back_where_lost,
    recovers,
    transition,
    weak_frame,
)
from human_tracker.vision.track.outcomes import TargetResult
from human_tracker.vision.track.parameters import TargetParameters, parameters_for
from human_tracker.vision.track.starts import (
    Hypothesis,
    best_hypothesis,
    cleared,
    initial_region,
    initial_states,
    may_switch,
    settle_on_box,
    should_start,
)

__all__ = [
    'TargetParameters',
    'TargetResult',
    'TargetTracker',
    'parameters_for',
]


class _Proposals(NamedTuple):
    """Stage 2's outcome (working pixels)."""

    detections: list[Detection] | None  # the faces delivered on this frame
    head_faces: list[Detection] | None  # the faces that are proposals (a head's), None for a hand
    states: np.ndarray | None  # the proposals' states, drawing particles
    region: np.ndarray | None  # the mask X_0 comes from
    starts: list[np.ndarray] | None  # X_0 of ``region`` when already computed


@dataclass
class TargetTracker(TrackFaces):
    """The contour particle filter plus cues, (re)starts and loss tests for one target: one
    frame's :meth:`step` on its :class:`~human_tracker.vision.track.state.Track`."""

    def process(
        self,
        image: np.ndarray,
        motion: np.ndarray | None = None,
        skin: np.ndarray | None = None,
        *,
        camera_motion: np.ndarray | None = None,
        stamp_ns: int | None = None,
        **kwargs: object,
    ) -> TargetResult:
        """:meth:`step` on the evidence of ``image`` and its cues
        (:class:`~human_tracker.vision.cues.evidence.Evidence`)."""
        return self.step(Evidence(image, motion, skin, camera_motion, stamp_ns), **kwargs)  # type: ignore[arg-type]

    def step(
        self, evidence: Evidence, face: Box | None = None, exclude: Sequence[Box] = (), avoid: Sequence[Box] = ()
    ) -> TargetResult:
        """Track on one frame.

        Args:
            evidence: The frame and its cues.
            face: With ``avoid_faces``: the face on this frame (x, y, w, h, camera pixels) where
                another tracker places it, used instead of a run of this track's own detector.
            exclude: Boxes (x, y, w, h, camera pixels) other targets hold: no start, hypothesis
                or face proposal is taken inside one (two filters must not settle on one person).
            avoid: With ``avoid_faces``: other people's faces on this frame (x, y, w, h, camera
                pixels): no start on one or its neck, a contour on one is a weak frame, and they
                are not skin to the likelihood.

        Returns:
            The outcome, its estimate in the camera's pixels.
        """
        if self.face_finder is None and self.faces.finder is not None:
            self.faces.finder.new_frame()  # its own detector: a frame is one step
        # 1. Observe.
        frame, cues = self._observe(evidence)
        p = self.parameters.scaled(self.scale)
        handed = face is not None and p.avoid_faces
        if handed:
            self.faces.hand_over(tuple(v * self.scale for v in face))  # type: ignore[union-attr]
        settled = self.start_box is not None and frame.bins is not None
        if settled:
            self._settle_on_start_box(cues, frame.bins)
        given_box = None if self.start_box is None else tuple(v * self.scale for v in self.start_box)
        self.start_box = None
        exclude = [tuple(v * self.scale for v in box) for box in exclude]
        avoided = [face_and_neck(tuple(v * self.scale for v in box)) for box in avoid] if p.avoid_faces else []
        if avoided and cues.likelihood_skin is not None:
            # The faces a hand keeps off are skin, but not the hand's.
            cues = cues._replace(likelihood_skin=cleared(cues.likelihood_skin, avoided))
        # 2. Propose.
        proposals = self._propose(frame, cues, exclude, avoided, evidence.stamp_ns, handed)
        # 3. Predict, weigh, resample.
        appearance = self._appearance_term(frame.bins)
        estimate = None
        if self.filter.initialised:
            estimate = self._filter_step(cues, appearance, self._drawing(proposals.states), **self._skin_draws())
        # 4. (Re)start.
        estimate, face_found, appearance, initialised = self._restart_on_faces(
            proposals, frame.bins, cues, estimate, appearance
        )
        if not initialised:
            estimate, initialised = self._start_on_hypothesis(proposals, cues, estimate, appearance)
        # 5. Verify.
        shown = tuple(tuple(v / self.scale for v in d.box) for d in proposals.detections or ())
        if estimate is None:
            self.reported_state = None
            return TargetResult(self.status, None, motion_set_aside=cues.motion_set_aside, detections=shown)
        if settled and not initialised:
            # The box sits on the person where the start frame's estimate puts the contour.
            self.anchor.box_relation = BoxRelation.of(given_box, estimate.state)
        estimate = self._verify(
            estimate, face_found, proposals, cues, frame, appearance, given_box, initialised, avoided
        )
        facing = (
            self.facing_votes.facing if self.parameters.proposals == 'faces' and self.detector is not None else None
        )
        return TargetResult(self.status, estimate, initialised, cues.motion_set_aside, shown, facing)

    def hypothesis(
        self,
        region: np.ndarray,
        edges: np.ndarray,
        motion: np.ndarray | None = None,
        skin: np.ndarray | None = None,
        appearance: Appearance | None = None,
        starts: list[np.ndarray] | None = None,
    ) -> Hypothesis | None:
        """The best-fitting state in clouds around the X_0 of ``region`` (``starts`` when they
        are already known), with its scores (working pixels)."""
        if starts is None:
            starts = initial_states(region, self.template, self.parameters.scaled(self.scale), self.filter.initialised)
        return best_hypothesis(self.filter, starts, edges, self.parameters, motion, skin, appearance)

    def _observe(self, evidence: Evidence) -> tuple[WorkingFrame, Cues]:
        """Stage 1: the frame and its cues at this track's working resolution; the particles
        carried with the camera's shake."""
        settings = self.frame_settings(evidence.image.shape[1])
        self._rescale(working_scale(evidence.image.shape[1], settings.width))
        frame = evidence.working(settings)
        cues = working_cues(evidence, frame, settings.width, self.parameters.scaled(self.scale))
        self._follow_camera(frame.grey, evidence.camera_motion)
        return frame, cues

    def _propose(
        self,
        frame: WorkingFrame,
        cues: Cues,
        exclude: list[Box],
        avoided: list[Box],
        stamp_ns: int | None,
        handed: bool,
    ) -> _Proposals:
        """Stage 2: faces (this track's detector as scheduled, unless a face was ``handed``
        over), skin regions, and the region X_0 comes from, kept off ``exclude`` and ``avoided``."""
        p = self.parameters.scaled(self.scale)
        waits = self.faces.waits(stamp_ns, p)
        detections = None if handed else self.faces.detect(frame.image, waits, p, self._predicted_face, self._carry)
        head_faces = detections if p.proposals == 'faces' else None
        if head_faces and exclude:
            head_faces = detections = [d for d in head_faces if not any(centre_within(d.box, b) for b in exclude)]
        place = self.face_place.relation
        states = np.array([place.state(d.box) for d in head_faces]) if head_faces else None
        kept_off = [*exclude, *avoided]
        if p.avoid_faces and self.faces.last_face is not None:
            kept_off.append(face_and_neck(self.faces.last_face))
        region = initial_region(cues.motion, cues.skin, p, kept_off)
        starts = None
        if p.proposals == 'skin' and cues.skin is not None:
            skin_region = region if p.init_region == 'skin' else initial_region(None, cues.skin, p, kept_off)
            skin_starts = initial_states(skin_region, self.template, p, self.filter.initialised)
            states = np.array(skin_starts) if skin_starts else None
            starts = skin_starts if skin_region is region else None
        return _Proposals(detections, head_faces, states, region, starts)

    def _filter_step(
        self, cues: Cues, appearance: Appearance | None, states: np.ndarray | None, **draws: object
    ) -> TrackEstimate:
        """Stage 3: the filter's predict, weigh and resample on ``cues``, ``states`` drawing particles."""
        motion, skin = cues.likelihood_motion, cues.likelihood_skin
        evidence, scale = cues.evidence, self.scale
        return self.filter.step(cues.edges, motion, skin, appearance, states, evidence=evidence, scale=scale, **draws)

    def _restart_on_faces(
        self,
        proposals: _Proposals,
        bins: np.ndarray | None,
        cues: Cues,
        estimate: TrackEstimate | None,
        appearance: Appearance | None,
    ) -> tuple[TrackEstimate | None, Detection | None, Appearance | None, bool]:
        """Stage 4a: a face where the filter has no (or a weak) target restarts it
        there. Returns the estimate, the face found on the head (None), the appearance term and
        whether the filter restarted. The appearance learnt before is kept if the face still
        looks like it (the light may have changed)."""
        p = self.parameters
        faces, states = proposals.head_faces, proposals.states
        face = None if estimate is None or not faces else face_on(faces, estimate.state, self.face_place.relation)
        restart = None if not faces else self._restart_on_face(states, face, estimate, appearance)
        if restart is not None:
            self.filter.initialise(states[restart])
            if bins is not None and (
                appearance is None or np.sqrt(appearance(states[restart : restart + 1])[0]) > p.lost_appearance_distance
            ):
                self.appearance = AppearanceModel.learn(bins, states[restart], self._own_region(), p.appearance_parts)
                appearance = self._appearance_term(bins)
            estimate = self._filter_step(cues, appearance, states)
            self.status, self.weak_frames = transition(self.status, Event.RESTART), 0
            face = faces[restart]
        if self.status == TRACKING:
            if faces is not None:
                self.faces.face_misses = 0 if face is not None else self.faces.face_misses + 1
            self.frames_without_own_face = 0 if face is not None else self.frames_without_own_face + 1
        return estimate, face, appearance, restart is not None

    def _start_on_hypothesis(
        self, proposals: _Proposals, cues: Cues, estimate: TrackEstimate | None, appearance: Appearance | None
    ) -> tuple[TrackEstimate | None, bool]:
        """Stage 4b: the region's best hypothesis starts the filter when there is no target, or
        when it is clearly better elsewhere. A new target's appearance is learnt once the filter
        has settled on it (:meth:`_verify`): X_0 from a region is coarse."""
        tracking = self.status == TRACKING
        named_by_box = self.started_from_box and self.appearance is not None
        if proposals.region is None or not may_switch(estimate, tracking, named_by_box, self.parameters):
            return estimate, False
        found = self.hypothesis(
            proposals.region, cues.edges, cues.motion, cues.likelihood_skin, appearance, proposals.starts
        )
        if found is None or not should_start(found, estimate, tracking, cues.motion is not None, self.parameters):
            return estimate, False
        self.filter.initialise(found.state)
        estimate = self._filter_step(cues, appearance, None)
        self.weak_frames = 0
        # A head whose face was seen is the head only once a face is found on it again.
        faced = self.parameters.proposals == 'faces' and self.anchor.face_relation is not None
        self.status = transition(self.status, Event.START_UNCONFIRMED if faced else Event.START)
        return estimate, True

    def _verify(
        self,
        estimate: TrackEstimate,
        face: Detection | None,
        proposals: _Proposals,
        cues: Cues,
        frame: WorkingFrame,
        appearance: Appearance | None,
        given_box: Box | None,
        initialised: bool,
        avoided: list[Box],
    ) -> TrackEstimate:
        """Stage 5: the box anchored, the weak-frame and loss tests, the appearance learnt, where
        a head faces; the estimate in camera pixels."""
        p = self.parameters.scaled(self.scale)
        state, bins = estimate.state, frame.bins
        last = self.faces.last_face
        own_face = [last] if self.faces.face_misses == 0 and last is not None else []
        # A contour on a face kept off is a weak frame: on the face itself for the hand's own
        # person, whose hand passes in front of their chin and neck (there the contour's own
        # fit decides, docs/decisions/hand-passes-before-its-face.md); on the face and neck for
        # other people's, in front of whom this hand has no business. On a face this frame's own
        # run found under it (not hidden by the hand) it is LOST at once.
        on_face = p.avoid_faces and any(centre_within(estimate.box, region) for region in [*own_face, *avoided])
        seen_on_face = p.avoid_faces and any(centre_within(estimate.box, d.box) for d in proposals.detections or ())
        if face is not None and self.status == TRACKING:
            self._anchor_on_face(face, state, given_box, initialised)
            self.faces.last_face = face.box
        looked = self._box_by_look(frame.grey, state, face, given_box)
        estimate = estimate.scaled(1.0 / self.scale)
        if looked is not None:
            estimate = replace(estimate, box=tuple(v / self.scale for v in looked))
        elif self.anchor.box_relation is not None:
            estimate = replace(estimate, box=self.anchor.box_relation.box(estimate.state))
        self.reported_state = state
        weak = on_face or weak_frame(
            estimate,
            self.parameters,
            cues,
            appearance is not None,
            self.usual_fit,
            partial(self._colours_beside, bins, state),
        )
        self.weak_frames = self.weak_frames + 1 if weak else 0
        self.steady_frames = 0 if weak else self.steady_frames + 1
        if not weak and self.status == TRACKING:
            self.usual_fit.add(estimate.confidence)
            if face is not None and not initialised:  # a restart put the contour on the face's place
                self.face_place.add(face.box, state)
        if not weak and self.status == TRACKING and bins is not None:
            if self.appearance is not None:
                self.appearance.adapt(bins, state, p.adaptation_rate)
            elif (estimate.motion_support if cues.motion is not None else estimate.confidence) + p.switch_margin >= 1:
                # A target found in a region is learnt once no hypothesis could beat its support.
                self.appearance = AppearanceModel.learn(bins, state, self._own_region(), p.appearance_parts)
        faces = self.parameters.proposals == 'faces' and self.detector is not None
        if self.weak_frames >= p.lost_frames or seen_on_face:
            if self.status == TRACKING:
                self.lost_at = estimate.state.copy()
            self.status = transition(self.status, Event.LOSS)
        elif self.status == LOST and (
            recovers(
                self.weak_frames,
                self.steady_frames,
                self.parameters,
                region=proposals.region is not None,
                faces=faces,
                skin=cues.likelihood_skin is not None,
            )
            or (faces and back_where_lost(estimate.state, self.lost_at, self.steady_frames, self.parameters))
        ):
            self.status = transition(self.status, Event.RECOVERY)
        if self.status != TRACKING:
            self.facing_votes.clear()
        elif proposals.head_faces is not None and not weak:  # a run looked at a head that fits
            self._vote_facing(face, frame, state)
        if self.status == TRACKING and self.steady_frames >= p.lost_frames:
            # Only a size held as long as a loss takes changes the frame's size.
            self._fit_resolution(float(estimate.state[2]), self.scale)
        return estimate

    def _colours_beside(self, bins: np.ndarray | None, state: np.ndarray) -> bool:
        """Whether the target's colours are in view beside the contour at ``state`` (working
        pixels; :meth:`~.appearance.AppearanceModel.distance_beside`)."""
        if bins is None or self.appearance is None:
            return False
        return self.appearance.distance_beside(bins, state) <= self.parameters.lost_appearance_distance

    def _settle_on_start_box(self, cues: Cues, bins: np.ndarray) -> None:
        """Start the filter where the contour best fits the silhouette around the start box; the
        box's place on that contour is the region whose colours are the target's appearance."""
        assert self.start_box is not None
        box = tuple(v * self.scale for v in self.start_box)
        best = settle_on_box(self.filter, box, cues.edges, cues.likelihood_motion, cues.likelihood_skin)
        self.filter.initialise(best)
        self.anchor.box_relation = BoxRelation.of(box, best)
        self.appearance = AppearanceModel.learn(bins, best, self.anchor.box_relation, self.parameters.appearance_parts)

    def _follow_camera(self, grey: np.ndarray, given: np.ndarray | None) -> None:
        """Carry the particles with the camera's shake since the last frame (``compensate_camera``)."""
        p = self.parameters
        if not p.compensate_camera:
            self.camera.previous, self.camera.motion = grey, None
            return
        particles = self.filter.particles
        estimate, smoothing = p.estimate_camera_motion, p.pan_smoothing
        shake = self.camera.follow(grey, given, self.scale, particles, estimate=estimate, pan_smoothing=smoothing)
        if shake is not None:
            self.filter.follow_camera(shake)

    def _skin_draws(self) -> dict[str, object]:
        """How skin regions draw particles, unlike faces: a region's moments are as coarse as X_0
        (spread as a hypothesis's cloud), and a region is not a hand, so none restarts the filter:
        the draws keep the importance correction, and a lost hand comes back through a hypothesis."""
        if self.parameters.proposals != 'skin':
            return {}
        spread = 2.0 * np.asarray(self.filter.parameters.initial_spread)
        return {'detection_spread': spread, 'restart_share': 0.0, 'detection_floor': 1.0}
