"""A target's track between frames: its filter and state, at its working resolution.

:class:`Track` holds what one frame's step (:class:`~human_tracker.vision.track.target.TargetTracker`)
reads and leaves for the next: the contour filter and its working resolution, the lifecycle
state and its counters, the appearance learnt, the face schedule and the box's anchor, the
camera's shake. It starts, stops and converts between working and camera pixels; the stages of
a frame are the tracker's.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import partial

import numpy as np

from human_tracker.vision.cues.appearance import AppearanceModel
from human_tracker.vision.cues.camera_motion import CameraShake
from human_tracker.vision.cues.evidence import FrameSettings
from human_tracker.vision.cues.resolution import finest_scale, track_width, working_scale
from human_tracker.vision.faces.anchoring import FRESH_FACE_FRAMES, BoxAnchor, FacePlace
from human_tracker.vision.faces.box_look import BoxLook
from human_tracker.vision.faces.detector import FaceDetector
from human_tracker.vision.faces.facing import FaceLook, FacingVotes
from human_tracker.vision.faces.finder import FaceFinder
from human_tracker.vision.faces.schedule import FaceSchedule
from human_tracker.vision.filter.contour_filter import Appearance, ContourTracker, TrackerParameters, state_from_box
from human_tracker.vision.filter.templates import ContourTemplate
from human_tracker.vision.geometry.boxes import Box, BoxRelation
from human_tracker.vision.track.lifecycle import WAITING, Event, TrackState, UsualFit, transition
from human_tracker.vision.track.parameters import TargetParameters

__all__ = ['Track']


@dataclass
class Track:
    """One target's filter and state between frames.

    Frames, boxes, estimates and parameters are in the camera's pixels; the filter itself
    (``filter``) works at the working resolution, ``scale`` working pixels per camera pixel.
    """

    template: ContourTemplate
    filter_parameters: TrackerParameters = field(default_factory=TrackerParameters)
    parameters: TargetParameters = field(default_factory=TargetParameters)
    status: TrackState = WAITING
    weak_frames: int = 0
    steady_frames: int = 0
    # The face detector's searches, shared with the other targets of a person tracker; None:
    # a detector of its own when the target wants faces.
    face_finder: FaceFinder | None = field(default=None, repr=False)
    filter: ContourTracker = field(init=False)
    scale: float = field(default=1.0, init=False)
    # The least working pixels per camera pixel this track needs (``min_target_width``), or None.
    finest_scale: float | None = field(default=None, init=False)
    appearance: AppearanceModel | None = field(default=None, init=False)
    anchor: BoxAnchor = field(default_factory=BoxAnchor, init=False)
    face_place: FacePlace = field(default_factory=FacePlace, init=False)
    faces: FaceSchedule = field(init=False)
    frames_without_own_face: int = field(default=0, init=False)
    # A face that would take the holding head off its contour, seen on one run: its head state
    # and the schedule's frame count then (:meth:`TargetTracker._restart_on_face`).
    disputing_face: tuple[np.ndarray, int] | None = field(default=None, init=False, repr=False)
    # The estimate (x, y, scale, θ, camera pixels) on the frame it was last lost: a LOST head
    # whose contour holds there again is TRACKING (:func:`~.lifecycle.back_where_lost`).
    lost_at: np.ndarray | None = field(default=None, init=False, repr=False)
    # The edge fit of its steady frames, what a weak frame falls below.
    usual_fit: UsualFit = field(default_factory=UsualFit, init=False)
    camera: CameraShake = field(default_factory=CameraShake, init=False)
    # The state reported on the last frame (working pixels): with ``detector_thread``, the
    # contour on the frame the faces delivered on this one were found on.
    reported_state: np.ndarray | None = field(default=None, init=False, repr=False)
    start_box: Box | None = field(default=None, init=False)
    started_from_box: bool = field(default=False, init=False)
    # Where a followed head faces: its detector runs' verdicts (:mod:`~human_tracker.vision.faces.facing`).
    facing_votes: FacingVotes = field(default_factory=FacingVotes, init=False)
    face_look: FaceLook = field(default_factory=FaceLook, init=False)
    # The reported box's grey levels, for a head between the faces that anchor it.
    box_look: BoxLook = field(default_factory=BoxLook, init=False)

    def __post_init__(self) -> None:
        self.parameters.validate()
        self.filter = ContourTracker(self.template, self.filter_parameters)
        self.faces = FaceSchedule.for_target(self.parameters, self.face_finder)

    @property
    def detector(self) -> FaceDetector | None:
        """The face detector, None when the target wants none or dlib is missing."""
        return self.faces.detector

    @property
    def has_fresh_face(self) -> bool:
        """Whether a head's own face was found on it within ``FRESH_FACE_FRAMES`` frames."""
        return self._fresh_face() is not None

    @property
    def proposals_problem(self) -> str | None:
        """Why the face detector asked for is off (dlib missing), or None."""
        if self.parameters.wants_faces and self.detector is None:
            wanted = 'proposals: faces' if self.parameters.proposals == 'faces' else 'avoid_faces'
            return f'{wanted} needs dlib (pip install dlib-bin, or apt install python3-dlib); running without'
        return None

    def _to_camera(self) -> np.ndarray:
        """Per-component factors taking a state [x, y, s, θ] from working to camera pixels."""
        return np.array([1.0 / self.scale, 1.0 / self.scale, 1.0 / self.scale, 1.0])

    def set_filter_parameters(self, parameters: TrackerParameters) -> None:
        """Change the filter's constants (camera pixels) while it runs."""
        self.filter_parameters = parameters
        self.filter.parameters = parameters.scaled(self.scale)

    @property
    def particles(self) -> np.ndarray | None:
        """``(P, 4)`` particle cloud in camera pixels, or None before initialisation."""
        return None if self.filter.particles is None else self.filter.particles * self._to_camera()

    @property
    def previous_particles(self) -> np.ndarray | None:
        """``(P, 4)`` each particle's state on the frame before (the AR(2) state's x_{k-1}),
        camera pixels, or None before initialisation."""
        return None if self.filter.previous is None else self.filter.previous * self._to_camera()

    def initialise_from_box(self, box: Box) -> None:
        """Start on a known box (x, y, w, h), camera pixels (benchmark protocol, an operator, a detector).

        The box fills the template's reference region, and every later box is reported the way
        this one sits on the contour (:mod:`~human_tracker.vision.geometry.boxes`): a face box stays a
        face box. With the fused likelihood the contour settles on the silhouette around the box
        on the next frame (:func:`~human_tracker.vision.track.starts.settle_on_box`), and the box's
        colours are the target's appearance.
        """
        state = state_from_box(box, self.template)
        self.filter.initialise(state / self._to_camera())
        self._forget_target()
        self._fit_resolution(float(state[2]), 0.0)  # before the frame's size is known
        self.anchor = BoxAnchor(BoxRelation.of(box, state))  # until the contour settles on the next frame
        self.start_box = tuple(float(v) for v in box)  # type: ignore[assignment]
        self.started_from_box = True
        self.faces.drop_pending()  # its faces belong to the frame before the box
        self.status = transition(self.status, Event.START)

    def decline(self) -> None:
        """Say the target the filter found may not be taken up: it still waits (never taken up)."""
        self.status = transition(self.status, Event.DECLINE)

    def mark_lost(self) -> None:
        """Declare the target lost (the next hypothesis may restart the filter)."""
        self.status = transition(self.status, Event.MARK_LOST)

    def reset(self) -> None:
        """Forget the target; wait for motion or a box."""
        self.filter.reset()
        self.status = transition(self.status, Event.RESET)
        self._forget_target()
        self.steady_frames = 0
        self.reported_state = self.start_box = None
        self.anchor = BoxAnchor()
        self.faces.reset()
        self.camera = CameraShake()
        self.started_from_box = False
        self.facing_votes.clear()

    def _forget_target(self) -> None:
        """Forget what was learnt of the target followed so far: its fit, where it was lost, its
        looks and its resolution (a reset, or a new start from a box)."""
        self.weak_frames = self.frames_without_own_face = 0
        self.disputing_face = self.lost_at = self.appearance = self.finest_scale = None
        self.usual_fit = UsualFit()
        self.face_look.clear()
        self.face_place.clear()
        self.box_look.clear()

    def frame_settings(self, frame_width: int) -> FrameSettings:
        """What this track's working frame of a frame ``frame_width`` pixels wide depends on."""
        width = self.working_width(frame_width)
        p = self.parameters.scaled(working_scale(frame_width, width))
        return FrameSettings(
            width, p.colour_edges, p.likelihood == 'fused', p.edge_blur_sigma, p.canny_low, p.canny_high
        )

    def _fresh_face(self) -> Box | None:
        """The head's own face when it was found within ``FRESH_FACE_FRAMES`` frames, else None."""
        fresh = self.frames_without_own_face <= FRESH_FACE_FRAMES
        return self.faces.last_face if fresh else None

    def _own_region(self) -> BoxRelation:
        """The region whose colours are the target's after a start by itself: the template's
        reference region (the head's or the hand's box)."""
        return BoxRelation.of(self.template.reference_box, np.array([0.0, 0.0, 1.0, 0.0]))

    def _appearance_term(self, bins: np.ndarray | None) -> Appearance | None:
        """D² of states on this frame's colour ``bins``, once the target's appearance is known."""
        if bins is None or self.appearance is None:
            return None
        return partial(self.appearance.squared_distances, bins)

    def working_width(self, frame_width: int) -> int:
        """The width frames ``frame_width`` pixels wide are reduced to for this track
        (:func:`~human_tracker.vision.cues.resolution.track_width`)."""
        return track_width(frame_width, self.parameters.working_width, self.finest_scale)

    def _fit_resolution(self, target_width: float, scale: float) -> None:
        """Keep a target ``target_width`` camera pixels wide at least ``min_target_width`` working
        pixels across from the next frame on (:func:`~human_tracker.vision.cues.resolution.finest_scale`)."""
        self.finest_scale = finest_scale(target_width, scale, self.parameters.min_target_width) or self.finest_scale

    def _rescale(self, scale: float) -> None:
        """Work at ``scale`` working pixels per camera pixel (first frame, a new frame size, or a
        target that needs a finer frame)."""
        if scale == self.scale:
            return
        ratio = scale / self.scale
        factors = np.array([ratio, ratio, ratio, 1.0])  # a state [x, y, s, θ] at the new scale
        if self.filter.particles is not None and self.filter.previous is not None:
            self.filter.particles = self.filter.particles * factors
            self.filter.previous = self.filter.previous * factors
        if self.camera.previous is not None:
            # No camera motion or face localisation across frames of two sizes.
            self.faces.rescale(ratio)
            if self.reported_state is not None:
                self.reported_state = self.reported_state * factors
            self.camera.previous = None
        self.scale = scale
        self.filter.parameters = self.filter_parameters.scaled(scale)
