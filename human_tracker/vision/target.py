"""Following one target: the contour tracker with motion cues, automatic (re)initialisation
and loss detection. This is what a node or the offline command runs per frame.

Per frame: the edge map is computed; a motion mask (foreground of the background model, or
optical-flow motion) enters the likelihood as eqs. 3-4 (``weighted``), or restricts the edges
to moving pixels (``mask``, the variant §2.4.2 shows to fail when the person stops). A mask
over most of the frame is set aside (``max_motion_fraction``): the background model of
§2.4.1 assumes a fixed camera, and when the camera moves (the real ``david`` sequence: 78 %
of a frame foreground, median) every edge "moves", so the mask cannot tell the person from
the room, and its region, the whole frame, is no X_0.

The moving region's §2.5 estimate X_0 is a hypothesis, scored by the fraction of contour
points that find an edge (best over a small cloud around X_0). It starts the filter when the
filter has no target (WAITING, LOST) and the score reaches ``init_confidence``. It restarts
the filter elsewhere when its *moving* score (points whose edge lies on the motion mask)
beats the current estimate's by ``switch_margin`` while fitting at least ``lost_confidence``
of its points: the person came back, or the filter slid onto still clutter that fits the
template as well as the person does; not while the edges and colours of a target started from
a box (the box names it) hold. The target is lost when, for ``lost_frames`` frames in
a row, fewer than ``lost_confidence`` of the points find an edge, or (with
``lost_motion_support`` > 0) fewer than that fraction lie on the motion mask. The second
test suits the background cue, where a person who stands still is still foreground; with
optical flow a still person does not move, so it stays off there. A lost target comes back
through a motion hypothesis when a mask is given (the filter's own fit on clutter is no
evidence of the person), when the edges fit again when there is no mask (unless faces are the
proposals: then through a face), and, with skin labels, after ``lost_frames`` frames in a
row that are not weak.

Skin labels (§3.2) enter in one of the paper's two ways (``colour_mode``): the colour term
γ_colour in the likelihood (``weighted``), or as the area the template is fitted in
(``mask``: edges only near skin). They can also delimit the region X_0 comes from
(``init_region``): for a hand, skin regions, so that moving clothes do not start the
filter (the template's fit tells the hand from the face and skin-coloured things).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from functools import partial
from typing import NamedTuple

import cv2
import numpy as np

from human_tracker.vision.appearance import AppearanceModel, colour_bins
from human_tracker.vision.boxes import Box, BoxRelation, box_centre, centre_within
from human_tracker.vision.camera_motion import estimate_camera_motion, move_states, scale_transform
from human_tracker.vision.exposure import normalise_exposure
from human_tracker.vision.faces import FACE_ON_HEAD, Detection, FaceDetector, face_detector_available
from human_tracker.vision.initialisation import blobs, moments_state, state_from_scan, upper_end_state
from human_tracker.vision.lifecycle import LOST, TRACKING, WAITING, Event, TrackState, transition
from human_tracker.vision.measurement import edge_map
from human_tracker.vision.morphology import disk
from human_tracker.vision.particle_filter import gaussian_cloud
from human_tracker.vision.resolution import same_frame, to_working, working_scale, working_shape
from human_tracker.vision.skin import SKIN
from human_tracker.vision.templates import ContourTemplate
from human_tracker.vision.tracker import Appearance, ContourTracker, TrackerParameters, TrackEstimate, state_from_box

__all__ = [
    'COLOUR_MODES',
    'INIT_METHODS',
    'INIT_REGIONS',
    'LIKELIHOODS',
    'PROPOSALS',
    'MOTION_MODES',
    'Hypothesis',
    'SharedFrames',
    'TargetParameters',
    'TargetResult',
    'TargetTracker',
    'parameters_for',
]

MOTION_MODES = ('off', 'weighted', 'mask')
COLOUR_MODES = ('off', 'weighted', 'mask')
INIT_METHODS = ('scan', 'moments')
INIT_REGIONS = ('motion', 'skin')
LIKELIHOODS = ('fused', 'paper')
PROPOSALS = ('faces', 'skin', 'off')

# Where the contour is sought around a start box: scale factors, and x / y offsets in units
# of the box's scale (the head-and-shoulders outline around a face box is larger and higher).
START_SCALES = tuple(np.round(np.linspace(1.0, 1.8, 9), 2))
START_OFFSETS = (tuple(np.round(np.linspace(-0.3, 0.3, 7), 2)), tuple(np.round(np.linspace(-0.6, 0.3, 10), 2)))

# A detected face belongs to the tracked head when its centre is within this many face widths
# of where the contour puts the face, and its size within this factor of that face's: a
# contour shrinking onto the face or the hair must still find its face (interview_alberto).
FACE_MATCH_DISTANCE = 0.75
FACE_MATCH_SIZE = 1.75
# A head's own face is fresh while it was found within this many frames: a face found away from
# the head then restarts it only within FACE_SIZE_CHANGE of that face's size or near where it
# was, and a hand is handed where the contour puts the face (people.py; a head that slid onto
# the raised arm would send the hand to the face).
FRESH_FACE_FRAMES = 4
FACE_SIZE_CHANGE = 1.25
# A finer working frame is taken with this margin over the one a small target needs
# (``min_target_width``).
RESOLUTION_MARGIN = 1.25
# Detector runs near the track in a row that found no face on it before one searches the
# whole frame.
SEARCH_AFTER_MISSES = 3
# The whole-frame search (upsampled once) finds faces from about this wide (working pixels);
# a smaller face last seen is searched for within this many of its sizes of where it was.
SMALLEST_FACE_IN_FRAME = 40.0
SEARCH_REACH = 4.0
# After this many detector runs in a row found no face, the detector runs on one frame in
# ``patient_every``: a whole-frame search costs 10-20 ms, and a robot often sees a person from
# behind, or a hand and no face.
PATIENT_SEARCHES = 8
# Frames without its face after which a head is weak when motion cannot support it: counted
# in frames, not detector runs, which thin out when no face is found (PATIENT_SEARCHES).
FACELESS_FRAMES = 30


@dataclass
class TargetParameters:
    """How cues are combined and when the target counts as lost.

    Attributes:
        likelihood: ``fused`` (the shape likelihood of eqs. 1-4 times the colour appearance
            term, :mod:`~human_tracker.vision.appearance`) or ``paper`` (shape only).
        appearance_parts: Horizontal bands of the target's region with their own histogram.
        adaptation_rate: How fast the appearance reference follows the target, per frame
            that is not weak (0 keeps the first frame's).
        lost_appearance_distance: Bhattacharyya distance of the region from its reference
            above which a frame is weak, and above which a hypothesis does not start the
            filter once the target's appearance is known.
        proposals: ``faces`` (face detections draw particles and start or restart the
            track, :mod:`~human_tracker.vision.proposals`; needs dlib), ``skin`` (the
            moments of the skin regions that hypotheses come from draw particles, spread as
            widely as a hypothesis's cloud: for a hand) or ``off``.
        detect_every: Run the detector on every this many frames (around the predicted face
            while tracking, on the whole working frame while searching).
        patient_every: Once ``PATIENT_SEARCHES`` runs in a row found no face, let at least this
            many frames pass between runs.
        face_search_reach: While the head is tracked the detector looks within this many
            face sizes of the predicted face; a run's time goes with its square. 1.5 costs a
            third less on real faces at the same precision on the six real heads, but hand2
            as a person lost precision on its hand (from the hand's box 0.435 -> 0.427) and had
            more runs with the hand confidently wrong over 5 % of the time (docs/evaluation.md).
        detector_thread: Run the detector in its own thread: a run on frame k goes on while
            the tracker finishes frame k and the next frame arrives, and its faces are used on
            frame k + 1, which waits for them (a replay gives the same track on any machine).
            False: on the frame it ran on, at that frame's cost.
        detector_wait_interval: With ``detector_thread``, a frame stamped more than this many
            seconds after the one before waits for its own detector run and uses its faces
            itself. Faces a frame late are carried by the filter's predicted motion, which a
            person turning back outruns when frames are far apart (a camera below 20 Hz, or
            frames dropped): at a third of their frame rate, from the first box, three seeds,
            sunshade 0.45 -> 0.89 (confident-wrong 28 % -> 7 %), david_colour 0.93 -> 0.99.
            Frames without stamps never wait.
        avoid_faces: For a hand: faces the detector finds (every ``detect_every`` frames,
            around the last one found) are not the target. A face is skin and about a hand's
            size, and a hand passing in front of it leaves the contour there: a contour on the
            face found last is a weak frame, and the face is cut from the skin regions that
            hypotheses come from. Needs dlib.
        compensate_camera: Carry the particles with the camera's own image motion between
            frames (:mod:`~human_tracker.vision.camera_motion`) before each prediction, so the
            AR(2) velocity is the target's own: the motion the background stage measured,
            handed to :meth:`TargetTracker.process` (no cost), or with
            ``estimate_camera_motion`` the tracker's own estimate. A robot's camera shakes
            (real sequences shaken by a random walk of crops: docs/evaluation.md).
        estimate_camera_motion: With ``compensate_camera``, estimate the motion here, away
            from the target, when none is handed (a tracker fed another process's masks, or
            the flow cue): about 1.4 ms a frame at 320x240.
        pan_smoothing: Weight of the past in the running mean of the camera's shift per
            frame, in [0, 1). That mean (a pan; an operator or a robot's head following the
            person, who then stays put in the image) is left to the AR(2) velocity, and only
            the rest (shake) carries the particles; 0 carries them with the whole motion,
            whose damped velocity then lags a camera that follows the person (sunshade; 0.7
            lost a frame there in two seeds of five, and kept more of the shake's gain).
        motion_mode: ``off`` (eqs. 1-2), ``weighted`` (eqs. 3-4) or ``mask`` (edges on moving
            pixels only).
        max_motion_fraction: A motion mask covering more of the frame than this isolates
            nothing (the camera moved, the light changed): the frame is then tracked on its
            edges alone (eq. 2) and gives no hypothesis. 1 keeps every mask.
        colour_mode: ``off``, ``weighted`` (the colour term of §3.2 in the likelihood) or
            ``mask`` (edges only within ``skin_margin`` of skin: skin regions delimit the fit).
        skin_margin: Dilation, pixels, of the skin regions in the ``mask`` colour mode.
        init_region: Where X_0 comes from: ``motion`` (the moving region) or ``skin`` (skin
            regions); when that cue is missing on a frame, the other one.
        init_method: ``scan`` (§2.5.2, head from the top of the moving region) or ``moments``
            (§2.5.1, blob moments; for a hand or a head alone).
        upper_end_restarts: With ``moments``, once the filter has been started, X_0 of a
            region at least twice as long as wide is its upper end's
            (:func:`~human_tracker.vision.initialisation.upper_end_state`): a hand raised with
            its forearm, or held before the body, restarts on the hand, not on the forearm
            (hand2, twenty seeds from the box, with mixed skin clusters split: +0.046). Not
            for the first start: hands merged with skin-coloured shapes beside them then start
            off the hand.
        upright_angle: θ_upright of the scan initialisation, radians.
        min_blob_area: Smallest moving region, pixels, that can start or restart a track.
        region_closing: Radius (pixels) of the closing that joins a moving silhouette's parts
            before the region is measured (§2.5); 0 disables it.
        init_confidence: Score a motion hypothesis needs to start the filter, in [0, 1].
        switch_margin: How much better than the current estimate a hypothesis elsewhere must
            score to restart the filter there (never while the edges and colours of a target
            started from a box hold, with the fused likelihood).
        hypothesis_samples: States drawn around X_0 (twice ``initial_spread``) to score it.
        hypothesis_blobs: With ``moments``, how many of the largest regions each give an X_0
            (the best-fitting one wins: the hand among the skin-coloured regions).
        lost_confidence: Fraction of contour points finding an edge below which a frame is weak.
        lost_motion_support: Fraction of contour points on the motion mask below which a
            frame with a mask is weak; 0 disables the test (use it with the foreground cue).
        lost_skin_support: Share of the contour's interior on skin below which a frame with
            skin labels is weak (a hand that left the view leaves the contour on the room);
            0 disables the test.
        init_motion_support: With a motion mask, the fraction of a hypothesis's contour
            points on it that the hypothesis needs to start the filter: for a hand, found
            among the skin regions that move, not on skin-coloured things that stand still.
        lost_frames: Consecutive weak frames after which the target is lost.
        colour_edges: Detect edges on the colour image (strongest channel per pixel) when
            ``process`` is given one, not on its intensity.
        edge_blur_sigma: Gaussian pre-filter of the edge detector, pixels.
        canny_low: Canny low threshold.
        canny_high: Canny high threshold.
        working_width: Frames wider than this many pixels are reduced to it before the
            edges are found and the contour fitted (:mod:`~human_tracker.vision.resolution`);
            0 works at full size. Every length above and in the filter's parameters stays
            in the camera's pixels.
        min_target_width: Narrowest a target may be on the working frame, pixels (its scale
            s): a smaller start box, or a target held smaller for ``lost_frames``, makes the
            tracker reduce the frame less for that track, down to not at all. The contour
            cannot follow a target a few pixels across (docs/evaluation.md, *Small targets
            in wide frames*). 0: ``working_width`` alone decides.
    """

    likelihood: str = 'fused'
    appearance_parts: int = 2
    adaptation_rate: float = 0.02
    lost_appearance_distance: float = 0.5
    proposals: str = 'faces'
    detect_every: int = 1
    patient_every: int = 8
    face_search_reach: float = 2.0
    detector_thread: bool = True
    detector_wait_interval: float = 0.05
    avoid_faces: bool = False
    compensate_camera: bool = True
    estimate_camera_motion: bool = False
    pan_smoothing: float = 0.5
    motion_mode: str = 'weighted'
    max_motion_fraction: float = 0.5
    colour_mode: str = 'weighted'
    skin_margin: int = 4
    init_region: str = 'motion'
    init_method: str = 'scan'
    upper_end_restarts: bool = False
    upright_angle: float = 0.0
    min_blob_area: int = 1000
    region_closing: int = 4
    init_confidence: float = 0.45
    switch_margin: float = 0.2
    hypothesis_samples: int = 128
    hypothesis_blobs: int = 1
    lost_confidence: float = 0.3
    lost_motion_support: float = 0.0
    lost_skin_support: float = 0.0
    init_motion_support: float = 0.0
    lost_frames: int = 5
    colour_edges: bool = False
    edge_blur_sigma: float = 1.5
    canny_low: float = 40.0
    canny_high: float = 100.0
    working_width: int = 320
    min_target_width: float = 20.0

    def validate(self) -> None:
        """Raise ValueError naming the first parameter out of its range."""
        choices = {
            'likelihood': LIKELIHOODS,
            'proposals': PROPOSALS,
            'motion_mode': MOTION_MODES,
            'colour_mode': COLOUR_MODES,
            'init_method': INIT_METHODS,
            'init_region': INIT_REGIONS,
        }
        for name, allowed in choices.items():
            if getattr(self, name) not in allowed:
                raise ValueError(f'{name} must be one of {", ".join(allowed)}, got {getattr(self, name)!r}')
        if self.avoid_faces and self.proposals == 'faces':
            raise ValueError('avoid_faces is for a hand: with proposals: faces, faces are the target')
        if self.detect_every < 1:
            raise ValueError(f'detect_every must be >= 1, got {self.detect_every}')
        if self.patient_every < 1:
            raise ValueError(f'patient_every must be >= 1, got {self.patient_every}')
        if not self.face_search_reach > 0.0:
            raise ValueError(f'face_search_reach must be > 0, got {self.face_search_reach}')
        if not self.detector_wait_interval >= 0.0:
            raise ValueError(f'detector_wait_interval must be >= 0 (s), got {self.detector_wait_interval}')
        if self.appearance_parts < 1:
            raise ValueError(f'appearance_parts must be >= 1, got {self.appearance_parts}')
        for name in ('adaptation_rate', 'lost_appearance_distance'):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f'{name} must be in [0, 1], got {getattr(self, name)}')
        if not 0.0 <= self.pan_smoothing < 1.0:
            raise ValueError(f'pan_smoothing must be in [0, 1), got {self.pan_smoothing}')
        if not 0.0 < self.max_motion_fraction <= 1.0:
            raise ValueError(f'max_motion_fraction must be in (0, 1], got {self.max_motion_fraction}')
        if self.skin_margin < 0:
            raise ValueError(f'skin_margin must be >= 0, got {self.skin_margin}')
        if self.min_blob_area < 1:
            raise ValueError(f'min_blob_area must be >= 1, got {self.min_blob_area}')
        if not 0.0 <= self.init_confidence <= 1.0 or not 0.0 <= self.switch_margin <= 1.0:
            raise ValueError(
                f'init_confidence and switch_margin must be in [0, 1], got {self.init_confidence}, {self.switch_margin}'
            )
        if self.hypothesis_samples < 1 or self.hypothesis_blobs < 1:
            raise ValueError(
                f'hypothesis_samples and hypothesis_blobs must be >= 1, got '
                f'{self.hypothesis_samples}, {self.hypothesis_blobs}'
            )
        for name in ('lost_confidence', 'lost_motion_support', 'lost_skin_support', 'init_motion_support'):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f'{name} must be in [0, 1], got {getattr(self, name)}')
        if self.lost_frames < 1:
            raise ValueError(f'lost_frames must be >= 1, got {self.lost_frames}')
        if self.canny_low < 0 or self.canny_high < self.canny_low:
            raise ValueError(f'need 0 <= canny_low <= canny_high, got {self.canny_low}, {self.canny_high}')
        if self.working_width < 0:
            raise ValueError(f'working_width must be >= 0 (0: full size), got {self.working_width}')
        if self.min_target_width < 0:
            raise ValueError(f'min_target_width must be >= 0, got {self.min_target_width}')

    def scaled(self, factor: float) -> TargetParameters:
        """The same parameters on images resized by ``factor``: lengths and areas in pixels scaled."""
        if factor == 1.0:
            return self
        return replace(
            self,
            skin_margin=round(self.skin_margin * factor),
            min_blob_area=max(1, round(self.min_blob_area * factor**2)),
            region_closing=round(self.region_closing * factor),
            edge_blur_sigma=self.edge_blur_sigma * factor,
        )


def parameters_for(target: str) -> TargetParameters:
    """Defaults suited to a built-in target.

    The head starts from the top of the moving region (§2.5.2) and fits intensity edges. The
    hand starts from the moments (§2.5.1) of skin regions and fits colour edges: a hand is
    often as bright as what is behind it, but rarely the same colour. Skin regions away from
    the face draw particles (a waving hand outruns the AR(2) prediction), and the face is
    avoided. It keeps the paper's likelihood: on the real hand2 sequence the appearance term
    lost the hand sooner (precision 0.17 against 0.23, seeds 0-2), its palm histogram matching
    the skin-coloured wall.
    """
    if target == 'hand':
        # A hypothesis elsewhere takes over only with much more motion support than the
        # head needs: a hand stops and starts waving, and a swaying face or sleeve then moves
        # more (0.2 lost hand_cluttered's still hand in 2 seeds of 5), but a real hand's fast
        # swing leaves the contour on the wrist, and only a switch brings it back (hand2, 10
        # seeds: never switching 0.373, 0.3 0.432). A hand that leaves takes the skin from
        # inside the contour, so it is lost, and found again among the skin regions when it
        # comes back. A blurred waving hand keeps about half its contour's interior on skin.
        return TargetParameters(
            init_method='moments',
            upper_end_restarts=True,
            init_region='skin',
            proposals='skin',
            avoid_faces=True,
            likelihood='paper',
            hypothesis_blobs=3,
            switch_margin=0.3,
            lost_skin_support=0.5,
            init_motion_support=0.25,
            # A lost hand starts again only where 60 % of the contour finds an edge (a head:
            # 45 %): skin-coloured wood and a bare forearm offer regions a hand-shaped contour
            # half fits (hand2: starts on the drawers held for 15-24 frames, confident-wrong;
            # over 80 runs the runs above 5 % confident-wrong 4 -> 0, precision 0.422 -> 0.427).
            init_confidence=0.6,
            colour_edges=True,
            # The faces avoided: every third frame rather than every fifth lost the hand sooner
            # (0.40 -> 0.36, 5 seeds).
            detect_every=5,
            patient_every=20,
            # The fingers' outline needs more pixels than a head's: hand2 with the hand 32
            # working pixels wide 0.64, 24 wide (the frames halved) 0.29.
            min_target_width=32.0,
        )
    return TargetParameters()


class Hypothesis(NamedTuple):
    """A candidate state from the moving region and how well it fits.

    Attributes:
        state: ``(4,)`` [x, y, s, θ] in working pixels (what ``filter`` is initialised with).
        confidence: Fraction of contour points that found an edge.
        motion_support: Fraction of contour points whose edge moves.
        skin_support: Share of the contour's interior on skin (1 without skin labels).
        appearance_distance: Bhattacharyya distance of its region from the target's
            reference (0 while the appearance is unknown).
    """

    state: np.ndarray
    confidence: float
    motion_support: float
    skin_support: float = 1.0
    appearance_distance: float = 0.0


class WorkingFrame(NamedTuple):
    """What a tracker computes from a camera frame before its filter runs (working pixels).

    Attributes:
        image: ``(H, W)`` grey or ``(H, W, 3)`` BGR (``colour_edges``) working image, brightened
            (:func:`~human_tracker.vision.exposure.normalise_exposure`): what the edges and the face detector see.
        grey: The working grey image before brightening (the camera-motion estimate's).
        edges: Its :func:`~human_tracker.vision.measurement.edge_map`.
        bins: Its colour bins (:func:`~human_tracker.vision.appearance.colour_bins`) with the
            fused likelihood, else None.
    """

    image: np.ndarray
    grey: np.ndarray
    edges: np.ndarray
    bins: np.ndarray | None


# What the trackers of one frame compute once for all of them: working frames by their
# settings, and by ``('reduced', width)`` the frame reduced to a working width, as it is and
# brightened (``normalise_exposure``).
SharedFrames = dict[tuple, 'WorkingFrame | tuple[np.ndarray, np.ndarray]']


class _Search(NamedTuple):
    """One run of the face detector: the grey working frame it looks at, and the run."""

    grey: np.ndarray
    run: Callable[[], list[Detection]]


@dataclass
class TargetResult:
    """One frame's outcome.

    Attributes:
        status: WAITING (never had a target), TRACKING, or LOST.
        estimate: The filter's estimate, None while WAITING.
        initialised: Whether the filter was (re)initialised on this frame.
        motion_set_aside: Whether the frame's motion mask covered more than
            ``max_motion_fraction`` of it and was not used.
        detections: The detector's boxes (x, y, w, h, camera pixels) on this frame.
    """

    status: TrackState
    estimate: TrackEstimate | None
    initialised: bool = False
    motion_set_aside: bool = False
    detections: tuple[tuple[float, float, float, float], ...] = ()

    @property
    def tracking(self) -> bool:
        """Whether a pose should be published for this frame."""
        return self.status == TRACKING and self.estimate is not None


@dataclass
class TargetTracker:
    """The contour particle filter plus motion cues, initialisation and loss detection.

    Frames, boxes, estimates and parameters are in the camera's pixels; the filter itself
    (``filter``) works at the working resolution, ``scale`` working pixels per camera pixel.
    A hand that avoids faces can be handed the face of the person's head that another filter
    follows (``process(..., face=...)``, :mod:`~human_tracker.vision.people`): on such a frame
    its own detector does not run.
    """

    template: ContourTemplate
    filter_parameters: TrackerParameters = field(default_factory=TrackerParameters)
    parameters: TargetParameters = field(default_factory=TargetParameters)
    status: TrackState = WAITING
    weak_frames: int = 0
    steady_frames: int = 0
    filter: ContourTracker = field(init=False)
    scale: float = field(default=1.0, init=False)
    # The least working pixels per camera pixel this track needs (``min_target_width``), or None.
    finest_scale: float | None = field(default=None, init=False)
    appearance: AppearanceModel | None = field(default=None, init=False)
    box_relation: BoxRelation | None = field(default=None, init=False)
    face_relation: BoxRelation | None = field(default=None, init=False)
    face_misses: int = field(default=0, init=False)
    faceless_runs: int = field(default=0, init=False)
    frames_without_own_face: int = field(default=0, init=False)
    last_face: tuple[float, float, float, float] | None = field(default=None, init=False)
    previous_frame: np.ndarray | None = field(default=None, init=False)
    # The camera's motion since the last frame the particles were carried by (working pixels).
    camera_motion: np.ndarray | None = field(default=None, init=False)
    pan: np.ndarray = field(default_factory=lambda: np.zeros(2), init=False)  # pan_smoothing's mean shift
    # The state [x, y, s, θ] reported on the last frame (working pixels): with
    # ``detector_thread``, the contour on the frame the faces delivered on this one were found on.
    reported_state: np.ndarray | None = field(default=None, init=False, repr=False)
    start_box: tuple[float, float, float, float] | None = field(default=None, init=False)
    started_from_box: bool = field(default=False, init=False)
    detector: FaceDetector | None = field(default=None, init=False)
    frames: int = field(default=0, init=False)
    searched_on: int = field(default=0, init=False)  # the frame of the detector's last run
    detected_on: np.ndarray | None = field(default=None, init=False, repr=False)  # the grey frame of the last run
    # The detector's thread (``detector_thread``) and the run it has not delivered yet.
    _worker: ThreadPoolExecutor | None = field(default=None, init=False, repr=False)
    _pending: tuple[_Search, Future[list[Detection]]] | None = field(default=None, init=False, repr=False)
    # The last frame's stamp (ns), and whether the faces delivered on this frame were found on
    # the frame before (``detector_thread``) or on this one.
    _stamp_ns: int | None = field(default=None, init=False, repr=False)
    _faces_late: bool = field(default=False, init=False, repr=False)

    def __post_init__(self) -> None:
        self.parameters.validate()
        self.filter = ContourTracker(self.template, self.filter_parameters)
        if self._wants_faces and face_detector_available():
            self.detector = FaceDetector()
            if self.parameters.detector_thread:
                self._worker = ThreadPoolExecutor(1, 'face_detector')

    @property
    def _wants_faces(self) -> bool:
        return self.parameters.proposals == 'faces' or self.parameters.avoid_faces

    @property
    def has_fresh_face(self) -> bool:
        """Whether a head's own face was found on it within ``FRESH_FACE_FRAMES`` frames."""
        return self.last_face is not None and self.frames_without_own_face <= FRESH_FACE_FRAMES

    @property
    def proposals_problem(self) -> str | None:
        """Why the face detector asked for is off (dlib missing), or None."""
        if self._wants_faces and self.detector is None:
            wanted = 'proposals: faces' if self.parameters.proposals == 'faces' else 'avoid_faces'
            return f'{wanted} needs dlib (pip install dlib-bin, or apt install python3-dlib); running without'
        return None

    def set_filter_parameters(self, parameters: TrackerParameters) -> None:
        """Change the filter's constants (camera pixels) while it runs."""
        self.filter_parameters = parameters
        self.filter.parameters = parameters.scaled(self.scale)

    @property
    def particles(self) -> np.ndarray | None:
        """``(P, 4)`` particle cloud in camera pixels, or None before initialisation."""
        if self.filter.particles is None:
            return None
        return self.filter.particles * self._to_camera_factors()

    @property
    def previous_particles(self) -> np.ndarray | None:
        """``(P, 4)`` each particle's state on the frame before (the AR(2) state's x_{k-1}), camera
        pixels, or None before initialisation."""
        if self.filter.previous is None:
            return None
        return self.filter.previous * self._to_camera_factors()

    def initialise_from_box(self, box: tuple[float, float, float, float]) -> None:
        """Start on a known box (x, y, w, h), camera pixels (benchmark protocol, an operator, a detector).

        The box fills the template's reference region, and every later box is reported the
        way this one sits on the contour (:mod:`~human_tracker.vision.boxes`): a face box stays
        a face box. With the fused likelihood, the box is also the region whose colours the
        target's appearance is learnt from, on the next frame.
        """
        state = state_from_box(box, self.template)
        self.filter.initialise(state / self._to_camera_factors())
        self.finest_scale = None
        self._fit_resolution(float(state[2]), 0.0)  # before the frame's size is known
        self.box_relation = BoxRelation.of(box, state)  # until the contour settles on the next frame
        self.face_relation = None
        self.frames_without_own_face = 0
        self.start_box = tuple(float(v) for v in box)  # type: ignore[assignment]
        self.started_from_box = True
        self._pending = None  # its faces belong to the frame before the box
        self.appearance = None
        self.status = transition(self.status, Event.START)
        self.weak_frames = 0

    def mark_lost(self) -> None:
        """Declare the target lost (the next motion hypothesis may restart the filter)."""
        self.status = transition(self.status, Event.MARK_LOST)

    def reset(self) -> None:
        """Forget the target; wait for motion or a box."""
        self.filter.reset()
        self.status = transition(self.status, Event.RESET)
        self.weak_frames = self.steady_frames = 0
        self.appearance = None
        self.box_relation = None
        self.face_relation = None
        self.face_misses = 0
        self.faceless_runs = 0
        self.frames_without_own_face = 0
        self.last_face = None
        self.detected_on = None
        self._pending = None
        self._stamp_ns = None
        self.reported_state = None
        self.previous_frame = None
        self.pan = np.zeros(2)
        self.start_box = None
        self.started_from_box = False
        self.finest_scale = None
        self.frames = self.searched_on = 0

    def initial_region(
        self, motion: np.ndarray | None, skin: np.ndarray | None, exclude: Sequence[Box] = ()
    ) -> np.ndarray | None:
        """The mask X_0 is computed from (``init_region``), or None without the cues it needs;
        zero on the face to avoid (``avoid_faces``) and on ``exclude`` (boxes x, y, w, h, working
        pixels: other targets', other people's faces)."""
        if skin is not None:
            # Only the paper's skin clusters: parts of mixed ones (beside clothes of a near
            # colour) join the hand to the skin-coloured things next to it, and its X_0 strays.
            skin = np.where(skin == SKIN, skin, 0).astype(np.uint8)
        if self.parameters.init_region == 'skin' and skin is not None:
            region = skin
        else:
            region = motion if motion is not None else skin
        cleared = list(exclude)
        if self.parameters.avoid_faces and self.last_face is not None:
            cleared.append(_face_and_neck(self.last_face))
        return region if region is None or not cleared else _cleared(region, cleared)

    def initial_states(self, region: np.ndarray) -> list[np.ndarray]:
        """Candidate X_0 from a region mask (§2.5) at the working resolution; empty if there is no usable region."""
        p = self.parameters.scaled(self.scale)
        if p.region_closing:
            # Join the silhouette's moving parts into one region; the likelihood keeps the
            # tight mask so that still edges next to a moving person do not count as moving.
            region = cv2.morphologyEx(region, cv2.MORPH_CLOSE, disk(p.region_closing))
        if p.init_method == 'moments':
            starts = []
            for blob in blobs(region, p.min_blob_area, p.hypothesis_blobs):
                end = upper_end_state(blob, self.template) if p.upper_end_restarts and self.filter.initialised else None
                starts.append(moments_state(blob, self.template) if end is None else end)
            return starts
        start = state_from_scan(region, self.template, upright_angle=p.upright_angle, min_area=p.min_blob_area)
        return [] if start is None else [start]

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
        are already known), with its scores."""
        fp = self.filter.parameters
        best: tuple[float, Hypothesis] | None = None
        n = self.template.num_points
        # With a motion mask a start needs init_motion_support: a cloud with no moving pixel
        # within reach of its contours (their points, and δ along the normals) could not start,
        # and scored, it could hide a moving region that can.
        needs_motion = motion is not None and self.parameters.init_motion_support > 0
        # The farthest a contour point of any of the template's shapes lies from its origin.
        reach = max(float(np.hypot(*shape.points.T).max()) for shape in self.template.shapes)
        for start in self.initial_states(region) if starts is None else starts:
            if not fp.min_scale <= start[2] <= fp.max_scale:
                continue
            # Twice the initial spread: X_0 from a mask is coarse, the cloud must reach the silhouette.
            cloud = gaussian_cloud(
                start, 2.0 * np.asarray(fp.initial_spread), self.parameters.hypothesis_samples, self.filter.rng
            )
            cloud[0] = start
            np.clip(cloud[:, 2], fp.min_scale, fp.max_scale, out=cloud[:, 2])
            # Skipped after its draws, so that the random stream, and every later draw, stays the same.
            if needs_motion and not _moves_within(motion, cloud, reach, fp.search_halfwidth):
                continue
            fit = self.filter.fit(edges, cloud, motion, skin)
            # With colour the likelihood itself ranks the states; edges alone would favour
            # small contours that fit any clutter, so they rank by points on (moving) edges.
            score = -fit.costs if skin is not None else fit.matched + fit.moving - 1e-6 * fit.costs
            k = int(np.argmax(score))
            if best is None or score[k] > best[0]:
                skin_support = 1.0 if fit.skin is None else float(fit.skin[k])
                distance = 0.0 if appearance is None else float(np.sqrt(appearance(cloud[k : k + 1])[0]))
                hypothesis = Hypothesis(
                    cloud[k], float(fit.matched[k]) / n, float(fit.moving[k]) / n, skin_support, distance
                )
                best = (float(score[k]), hypothesis)
        return None if best is None else best[1]

    def process(
        self,
        image: np.ndarray,
        motion: np.ndarray | None = None,
        skin: np.ndarray | None = None,
        face: tuple[float, float, float, float] | None = None,
        exclude: Sequence[Box] = (),
        avoid: Sequence[Box] = (),
        shared: SharedFrames | None = None,
        camera_motion: np.ndarray | None = None,
        stamp_ns: int | None = None,
    ) -> TargetResult:
        """Track on one frame.

        Args:
            image: ``(H, W) uint8`` intensity image, or ``(H, W, 3) uint8`` BGR image.
            motion: Optional ``uint8`` mask, non-zero on moving pixels (foreground or
                optical-flow motion) of the same frame, at any resolution of it (a cue stage
                publishes at its own working width); it is brought to the working size.
            skin: Optional ``uint8`` skin labels of the same frame, likewise.
            face: With ``avoid_faces``: the face on this frame (x, y, w, h, camera pixels)
                where another tracker places it, used instead of a run of this tracker's
                own detector; None: the detector runs as scheduled.
            exclude: Boxes (x, y, w, h, camera pixels) other targets hold: no start, hypothesis
                or face proposal is taken inside one (two filters must not settle on one
                person).
            avoid: With ``avoid_faces``: other people's faces on this frame (x, y, w, h,
                camera pixels), kept off as the person's own: no start on one or its neck,
                and a contour on one is a weak frame; nor are they skin to the likelihood.
            shared: The working frames other trackers computed from this ``image``
                (:meth:`working_frame`), filled with this one's: trackers with the same
                working width and edge settings compute them once.
            camera_motion: With ``compensate_camera``, the camera's image motion from the
                last frame to this one (``(2, 3)``, :mod:`~human_tracker.vision.camera_motion`,
                camera pixels) as the background stage measured it; None: estimated here with
                ``estimate_camera_motion``, else not compensated on this frame.
            stamp_ns: The frame's time, nanoseconds (``detector_wait_interval``); None: unknown.

        Returns:
            The outcome, its estimate in the camera's pixels.
        """
        self._rescale(working_scale(image.shape[1], self.working_width(image.shape[1])))
        p = self.parameters.scaled(self.scale)
        motion = self._at_working('motion mask', motion, image.shape[:2])
        set_aside = motion is not None and int(np.count_nonzero(motion)) > p.max_motion_fraction * motion.size
        if set_aside:
            motion = None
        skin = self._at_working('skin labels', skin, image.shape[:2])
        handed = face is not None and p.avoid_faces
        if handed:
            self.last_face, self.face_misses = tuple(v * self.scale for v in face), 0
            self._pending = None  # the face handed over is this frame's
        frame = self.working_frame(image, shared)
        bins, image, edges = frame.bins, frame.image, frame.edges
        self._follow_camera(frame.grey, camera_motion)
        likelihood_motion = likelihood_skin = None
        if motion is not None and p.motion_mode == 'mask':
            edges = np.where(motion > 0, edges, 0).astype(np.uint8)
        elif motion is not None and p.motion_mode == 'weighted':
            likelihood_motion = motion
        if skin is not None and p.colour_mode == 'mask':
            near_skin = cv2.dilate(skin, disk(p.skin_margin))
            edges = np.where(near_skin > 0, edges, 0).astype(np.uint8)
        elif skin is not None and p.colour_mode == 'weighted':
            likelihood_skin = skin
        settled = self.start_box is not None and bins is not None
        if settled:
            # With the paper's likelihood the box fills the reference region as given: the grid
            # fit cost `david` 0.83 -> 0.63 there, while the fused likelihood gains from it.
            self._settle_on_start_box(edges, likelihood_motion, likelihood_skin, bins)
        given_box = None if self.start_box is None else tuple(v * self.scale for v in self.start_box)
        self.start_box = None
        exclude = [tuple(v * self.scale for v in box) for box in exclude]
        # The other faces kept off, with the skin around them (working pixels).
        avoided = [_face_and_neck(tuple(v * self.scale for v in box)) for box in avoid] if p.avoid_faces else []
        if avoided and likelihood_skin is not None:
            # The faces a hand keeps off are skin, but not the hand's: on them, a hand lost
            # behind the walker's head kept its filter on the walker's face, which carried it
            # away for 30 frames (people_crossing with two people, seed 16: 0.387 -> 0.933).
            likelihood_skin = _cleared(likelihood_skin, avoided)
        waits = self._waits_for_faces(stamp_ns)
        detections = None if handed else self._detect(image, waits)
        # Faces are the target's proposals, or (avoid_faces) what the hand is not: only the
        # proposals keep out of the other targets' boxes.
        head_faces = detections if p.proposals == 'faces' else None
        if head_faces and exclude:
            head_faces = detections = [d for d in head_faces if not any(centre_within(d.box, box) for box in exclude)]
        states = np.array([FACE_ON_HEAD.state(d.box) for d in head_faces]) if head_faces else None
        cleared = [*exclude, *avoided]
        region = self.initial_region(motion, skin, cleared)
        skin_region = skin_starts = None
        if p.proposals == 'skin' and skin is not None:
            skin_region = region if p.init_region == 'skin' else self.initial_region(None, skin, cleared)
            skin_starts = self.initial_states(skin_region)
            states = np.array(skin_starts) if skin_starts else None
        appearance = self._appearance_term(bins)
        estimate = (
            self.filter.step(edges, likelihood_motion, likelihood_skin, appearance, states, **self._skin_draws())
            if self.filter.initialised
            else None
        )
        initialised = False
        face = None if estimate is None or not head_faces else _face_on(head_faces, estimate.state)
        restart = None if not head_faces else self._restart_on_face(states, face, estimate, appearance)
        if restart is not None:
            # A face where the filter has no (or a weak, or a faceless) target: start there. The
            # appearance learnt before is kept if the face still looks like it (the light may
            # have changed).
            self.filter.initialise(states[restart])
            if bins is not None and (
                appearance is None or np.sqrt(appearance(states[restart : restart + 1])[0]) > p.lost_appearance_distance
            ):
                self.appearance = AppearanceModel.learn(bins, states[restart], self._own_region(), p.appearance_parts)
                appearance = self._appearance_term(bins)
            estimate = self.filter.step(edges, likelihood_motion, likelihood_skin, appearance, states)
            self.status, self.weak_frames, initialised = transition(self.status, Event.RESTART), 0, True
            face = detections[restart]
        if self.status == TRACKING:
            if head_faces is not None:
                self.face_misses = 0 if face is not None else self.face_misses + 1
            self.frames_without_own_face = 0 if face is not None else self.frames_without_own_face + 1
        found = None
        if region is not None and not initialised and self._may_switch(estimate):
            # The skin proposals' X_0 when they came from this region.
            starts = skin_starts if skin_region is region else None
            found = self.hypothesis(region, edges, motion, likelihood_skin, appearance, starts)
        if found is not None and self._should_start(found, estimate, motion is not None):
            # A new target's appearance is learnt once the filter has settled on it (below): X_0
            # from a region is coarse, and colours learnt there would hold the background.
            self.filter.initialise(found.state)
            estimate = self.filter.step(edges, likelihood_motion, likelihood_skin, appearance)
            self.weak_frames, initialised = 0, True
            # A head whose face was seen is the head only once a face is found on it again.
            faced = p.proposals == 'faces' and self.face_relation is not None  # set only by a detected face
            self.status = transition(self.status, Event.START_UNCONFIRMED if faced else Event.START)
        shown = tuple(tuple(v / self.scale for v in d.box) for d in detections or ())
        if estimate is None:
            self.reported_state = None
            return TargetResult(self.status, None, motion_set_aside=set_aside, detections=shown)
        working_state = estimate.state
        if settled and not initialised:
            # The box sits on the person where the start frame's estimate puts the contour: the
            # grid's best fit is one sample of that frame's edges (on head_cluttered, 8 px below
            # the head for the whole track).
            self.box_relation = BoxRelation.of(given_box, working_state)
        own_face = [self.last_face] if self.face_misses == 0 and self.last_face is not None else []
        on_face = p.avoid_faces and any(
            centre_within(estimate.box, region) for region in [*map(_face_and_neck, own_face), *avoided]
        )
        # A face this frame's own detector run found under the contour's centre is not hidden by
        # the hand, so the contour is on the face: LOST at once, not after `lost_frames`. (A face
        # found before, or handed over, may be behind the hand now: that is only a weak frame.)
        seen_on_face = p.avoid_faces and any(centre_within(estimate.box, d.box) for d in detections or ())
        if face is not None and self.status == TRACKING:
            self._anchor_on_face(face, working_state, given_box, initialised)
            self.last_face = face.box
        estimate = self._to_camera(estimate)
        if self.box_relation is not None:
            estimate = replace(estimate, box=self.box_relation.box(estimate.state))
        self.reported_state = working_state
        weak = estimate.confidence < p.lost_confidence or on_face
        if appearance is not None and estimate.appearance_distance > p.lost_appearance_distance:
            weak = True
        if motion is not None and estimate.motion_support < p.lost_motion_support:
            weak = True
        if likelihood_skin is not None and estimate.skin_support < p.lost_skin_support:
            weak = True
        faceless = self.frames_without_own_face >= FACELESS_FRAMES
        if motion is None and self.face_relation is not None and faceless:
            # A head whose face was seen, without it for a while and with no moving region to
            # say where the person is: the edge fit alone slides onto clutter (a panning camera).
            weak = True
        self.weak_frames = self.weak_frames + 1 if weak else 0
        self.steady_frames = 0 if weak else self.steady_frames + 1
        if not weak and self.status == TRACKING and bins is not None:
            if self.appearance is not None:
                self.appearance.adapt(bins, working_state, p.adaptation_rate)
            elif (estimate.motion_support if motion is not None else estimate.confidence) + p.switch_margin >= 1.0:
                # A target found in a region (X_0 is coarse) is learnt once the contour is on
                # it: once no hypothesis could beat its support.
                self.appearance = AppearanceModel.learn(bins, working_state, self._own_region(), p.appearance_parts)
        if self.weak_frames >= p.lost_frames or seen_on_face:
            self.status = transition(self.status, Event.LOSS)
        elif self.status == LOST and (
            (self.weak_frames == 0 and region is None and not (p.proposals == 'faces' and self.detector is not None))
            or (likelihood_skin is not None and self.steady_frames >= p.lost_frames)
        ):
            # Without a region cue the edge fit is the only evidence, unless faces are the
            # proposals (a lost head comes back through one: on a panning camera the edge fit
            # held a trellis); with a region, a lost target comes back through a hypothesis (an
            # edge fit on clutter is not the person), or after as many steady frames as made it
            # lost when skin under the contour says so (skin labels flicker off a hand for a
            # few frames).
            self.status = transition(self.status, Event.RECOVERY)
        if self.status == TRACKING and self.steady_frames >= p.lost_frames:
            # Only a size held as long as a loss takes: a contour that shrinks onto clutter
            # for a frame or two does not change the frame's size.
            self._fit_resolution(float(estimate.state[2]), self.scale)
        return TargetResult(self.status, estimate, initialised, set_aside, shown)

    def working_frame(self, image: np.ndarray, shared: SharedFrames | None = None) -> WorkingFrame:
        """The working image, colour bins and edges of a camera frame, taken from ``shared``
        (keyed by what they depend on) when another tracker computed them, else computed and
        put there."""
        width = self.working_width(image.shape[1])
        p = self.parameters.scaled(working_scale(image.shape[1], width))
        key = (width, p.colour_edges, p.likelihood, p.edge_blur_sigma, p.canny_low, p.canny_high)
        if shared is not None and key in shared:
            return shared[key]
        reduced = gained = None
        if p.likelihood == 'fused' or p.colour_edges or image.ndim == 2:
            # The frame as reduced and brightened serves the colour bins and colour edges of
            # every tracker.
            pair = None if shared is None else shared.get(('reduced', width))
            if pair is None:
                reduced = to_working(image, width)
                pair = (reduced, normalise_exposure(reduced))
                if shared is not None:
                    shared['reduced', width] = pair
            reduced, gained = pair
        bins = colour_bins(gained) if p.likelihood == 'fused' else None
        if reduced is None or (reduced.ndim == 3 and not p.colour_edges):
            # Grey before the reduction, as the cue stages do: a colour frame and its grey
            # version then give the same edges.
            reduced = to_working(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY), width)
            gained = normalise_exposure(reduced)
        grey = reduced if reduced.ndim == 2 else cv2.cvtColor(reduced, cv2.COLOR_BGR2GRAY)
        edges = edge_map(gained, blur_sigma=p.edge_blur_sigma, low_threshold=p.canny_low, high_threshold=p.canny_high)
        frame = WorkingFrame(gained, grey, edges, bins)
        if shared is not None:
            shared[key] = frame
        return frame

    def _settle_on_start_box(
        self, edges: np.ndarray, motion: np.ndarray | None, skin: np.ndarray | None, bins: np.ndarray
    ) -> None:
        """Start the filter where the contour best fits the silhouette around the start box.

        A start box need not be the template's reference region (a face box is smaller and
        lower than the head-and-shoulders outline around it): the contour is fitted on a grid
        of scales and offsets around the box (``START_SCALES``, ``START_OFFSETS``, in units of
        the box's own scale), the best fit (lowest Σ φ, eqs. 2-4) starts the filter, and the
        box's place on that contour is the region whose colours (``bins``) are the target's
        appearance. The boxes reported from then on sit on the contour as the box sits on this
        frame's estimate (:meth:`process`).
        """
        assert self.start_box is not None
        fp = self.filter.parameters
        box = tuple(v * self.scale for v in self.start_box)
        start = state_from_box(box, self.template)
        s0 = start[2]
        grid = np.array(
            [
                [start[0] + dx * s0, start[1] + dy * s0, s0 * factor, 0.0]
                for factor in START_SCALES
                for dy in START_OFFSETS[1]
                for dx in START_OFFSETS[0]
            ]
        )
        grid = np.vstack([start, grid])  # the box's own state first: it wins ties (a frame with no edges)
        np.clip(grid[:, 2], fp.min_scale, fp.max_scale, out=grid[:, 2])
        best = grid[int(np.argmin(self.filter.fit(edges, grid, motion, skin).costs))]
        self.filter.initialise(best)
        self.box_relation = BoxRelation.of(box, best)
        self.appearance = AppearanceModel.learn(bins, best, self.box_relation, self.parameters.appearance_parts)

    def _follow_camera(self, grey: np.ndarray, handed: np.ndarray | None) -> None:
        """Carry the particles with the camera's shake since the last frame (``compensate_camera``):
        its motion, ``handed`` (camera pixels) or estimated away from the target, less the
        running mean of its shift (``pan_smoothing``)."""
        previous, self.previous_frame = self.previous_frame, grey
        self.camera_motion = None
        particles = self.filter.particles
        p = self.parameters
        if not p.compensate_camera:
            return
        if handed is not None:
            transform = scale_transform(handed, self.scale)
        elif p.estimate_camera_motion and particles is not None and _same_shape(previous, grey):
            x, y, s = particles.mean(axis=0)[:3]
            exclude = np.zeros(grey.shape, np.uint8)
            # The head and shoulders (or the hand and forearm) around the state: it moves on its own.
            cv2.rectangle(exclude, (int(x - 1.5 * s), int(y - 1.5 * s)), (int(x + 1.5 * s), int(y + 2.5 * s)), 255, -1)
            transform = estimate_camera_motion(previous, grey, exclude)
        else:
            return
        if transform is None:
            return
        # The pan is followed while the filter waits too: a target found mid-pan is not shaken.
        self.pan = p.pan_smoothing * self.pan + (1.0 - p.pan_smoothing) * transform[:, 2]
        transform[:, 2] -= self.pan
        if particles is not None and not np.array_equal(transform, np.eye(2, 3)):
            self.camera_motion = transform
            self.filter.follow_camera(transform)

    def _waits_for_faces(self, stamp_ns: int | None) -> bool:
        """Whether this frame's detector run serves this frame: without ``detector_thread``, or
        when the frame comes more than ``detector_wait_interval`` after the one before (whose
        stamp it keeps: the next frame is timed from this one)."""
        last, self._stamp_ns = self._stamp_ns, stamp_ns
        if self._worker is None:
            return True
        if stamp_ns is None or last is None or stamp_ns <= last:
            return False
        return (stamp_ns - last) * 1e-9 > self.parameters.detector_wait_interval

    def _detect(self, image: np.ndarray, waits: bool) -> list[Detection] | None:
        """Faces for this working frame, None when no detector run delivers any on it.

        The detector runs every ``detect_every`` frames, and ``patient_every`` frames apart after
        ``PATIENT_SEARCHES`` runs found no face. With ``detector_thread`` a run's faces are
        delivered on the frame after the one it ran on, unless this frame ``waits`` for its own.
        """
        self.frames += 1
        delivered = None
        if self._pending is not None:
            (search, future), self._pending = self._pending, None
            delivered = self._carried(self._found(search, future.result()))
        search = self._search(image)
        self._faces_late = delivered is not None
        if search is None:
            return delivered
        if waits:
            self._faces_late = False
            return self._found(search, search.run())
        assert self._worker is not None
        self._pending = (search, self._worker.submit(search.run))
        return delivered

    def _search(self, image: np.ndarray) -> _Search | None:
        """The detector's run on this frame, if one is due."""
        p = self.parameters
        if self.detector is None or (self.frames - 1) % p.detect_every:
            return None
        if self.faceless_runs >= PATIENT_SEARCHES and self.frames - self.searched_on < p.patient_every:
            return None
        self.faceless_runs += 1
        self.searched_on = self.frames
        grey = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        run = self._face_search(grey) if self.parameters.proposals == 'faces' else self._avoided_face_search(grey)
        return _Search(grey, run)

    def _found(self, search: _Search, found: list[Detection]) -> list[Detection]:
        """Take a run's faces into the search's bookkeeping."""
        self.detected_on = search.grey
        if found:
            self.faceless_runs = 0
        if self.parameters.avoid_faces:
            if found:
                self.last_face, self.face_misses = found[0].box, 0
            else:
                if self.face_misses >= SEARCH_AFTER_MISSES:
                    self.last_face = None
                self.face_misses += 1
        return found

    def _carried(self, faces: list[Detection]) -> list[Detection]:
        """Faces found on the frame before, carried to where this frame's prediction puts them:
        by the camera's motion since then (``compensate_camera``) and the target's predicted
        displacement (the mean of the AR(2) prediction). Without it the box re-anchored on a
        face lags a walking person by a frame (sunshade, 15 px a frame: 0.993 -> 0.956)."""
        particles, previous = self.filter.particles, self.filter.previous
        if not faces or particles is None or previous is None:
            return faces
        velocity = self.filter.parameters.velocity_damping * (particles[:, :2] - previous[:, :2]).mean(axis=0)
        centres = np.array([[x + w / 2, y + h / 2, w, 0.0] for x, y, w, h in (face.box for face in faces)])
        moved = centres if self.camera_motion is None else move_states(centres, self.camera_motion)
        carried = []
        for face, (dx, dy) in zip(faces, (moved[:, :2] + velocity - centres[:, :2]).tolist(), strict=True):
            x, y, w, h = face.box
            carried.append(face._replace(box=(x + dx, y + dy, w, h), carried=(dx, dy)))
        return carried

    def _face_search(self, grey: np.ndarray) -> Callable[[], list[Detection]]:
        """Faces for the head's proposals: near the predicted face while the target is tracked;
        on the whole frame while it is not, or after ``SEARCH_AFTER_MISSES`` runs in a row found
        no face on it (a contour on clutter finds no face near itself), or, for a face last seen
        too small for that, around where it was. A target found by itself (not started from a
        box) is a head by its face, so for it one run without its face is enough."""
        assert self.detector is not None
        tracked = self.status == TRACKING and self.filter.particles is not None and self.weak_frames == 0
        patience = SEARCH_AFTER_MISSES if self.started_from_box else 1
        if tracked and self.face_misses < patience:
            predicted = self.filter.particles.mean(axis=0)
            reach = self.parameters.face_search_reach
            return partial(self.detector.detect_near, grey, FACE_ON_HEAD.box(predicted), reach=reach)
        self.face_misses = 0
        if self.last_face is not None and self.last_face[2] < SMALLEST_FACE_IN_FRAME:
            # A face too small for the whole-frame search: look around where it was last seen.
            return partial(self.detector.detect_near, grey, self.last_face, reach=SEARCH_REACH)
        return partial(self.detector.detect, grey, upsample=1)

    def _avoided_face_search(self, grey: np.ndarray) -> Callable[[], list[Detection]]:
        """Faces for ``avoid_faces``: around the last face found for ``SEARCH_AFTER_MISSES`` runs
        (the hand may hide it for a while), then on the whole frame."""
        assert self.detector is not None
        if self.last_face is not None and self.face_misses < SEARCH_AFTER_MISSES:
            return partial(self.detector.detect_near, grey, self.last_face)
        return partial(self.detector.detect, grey, upsample=1)

    def _skin_draws(self) -> dict[str, object]:
        """How skin regions draw particles, unlike faces: a region's moments are as coarse as X_0
        (spread as a hypothesis's cloud), and a region is not a hand (the room has skin-coloured
        wood, the arm its sleeve), so none restarts the filter: the draws keep the importance
        correction, and a lost hand comes back through a hypothesis."""
        if self.parameters.proposals != 'skin':
            return {}
        return {
            'detection_spread': 2.0 * np.asarray(self.filter.parameters.initial_spread),
            'restart_share': 0.0,
            'detection_floor': 1.0,
        }

    def _anchor_on_face(
        self,
        face: Detection,
        state: np.ndarray,
        given_box: tuple[float, float, float, float] | None = None,
        initialised: bool = False,
    ) -> None:
        """Re-anchor the reported box on the face detected on the tracked head (working pixels).

        The box a track reports is a region of the contour (``box_relation``); the contour of a
        head and shoulders does not say where the face is within it as the head turns, and
        its scale follows the hair and shoulders. A detected face does: the first face found
        on the head records how the reported box sits on it (``face_relation``, in units of
        the face's width), and each later one moves the reported box there and re-expresses
        it on the contour, which carries it until the next detection. A face found on the frame
        a box was given on (``given_box``, working pixels) relates to that box itself: the
        contour has already moved within the frame's filter step. A face the detector's thread
        delivers a frame late relates to the box reported on the frame it was found on
        (``reported_state``), carried as the face was; once the relation is known, such a face
        is placed on this frame by the mean of two estimates of the head's motion since: the
        filter's prediction, which carried it (:meth:`_carried`), and the contour's own
        displacement from the state reported then to this frame's. The prediction alone lags a
        head that moves faster than it predicts (sunshade, walking across a panning view: 12-22 px
        behind), the contour's displacement alone carries the contour's jitter onto the box.
        """
        (x, y, w, h), (dx, dy) = face.box, face.carried
        # The state reported on the frame a face the detector's thread delivers late was found on.
        then = None if not self._faces_late or initialised or given_box is not None else self.reported_state
        if self.face_relation is None and self.detector is not None and self.detected_on is not None:
            # The relation is kept for the whole track: it must not carry one detection's
            # jitter. Found again where it was found, on that frame.
            localise = partial(self.detector.localise, self.detected_on, (x - dx, y - dy, w, h))
            x, y, w, h = localise() if self._worker is None else self._worker.submit(localise).result()
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
            # An automatic start reports the head box: where the face puts the head
            # (FACE_ON_HEAD), not where this frame's contour happens to be.
            box = self._own_region().box(FACE_ON_HEAD.state((x, y, w, h)))
        self.face_relation = BoxRelation.of(box, face_state)

    def _restart_on_face(
        self,
        states: np.ndarray,
        face: Detection | None,
        estimate: TrackEstimate | None,
        appearance: Appearance | None,
    ) -> int | None:
        """Which detection (index into ``states``) restarts the filter, or None.

        The best one when there is no target, when the target is weak, or when the target was
        found by itself (not started from a box) and the face is not on it (while its own face
        is fresh, the best that could be that face: :meth:`_could_be_own_face`). While a target
        started from a box is tracked without its face, a face that looks more like the target
        than the estimate does (a contour that slid onto clutter, or shrank onto part of the head).
        """
        if self.status != TRACKING or self.weak_frames > 0 or estimate is None:
            return 0
        if face is not None:
            return None
        if not self.started_from_box:
            # A target found by itself is a head by its face: without its face, this one is.
            return self._could_be_own_face(states)
        if appearance is None:
            return None
        distances = np.sqrt(appearance(states))
        k = int(np.argmin(distances))
        limit = min(self.parameters.lost_appearance_distance, estimate.appearance_distance)
        return k if distances[k] < limit else None

    def _could_be_own_face(self, states: np.ndarray) -> int | None:
        """The first of ``states`` (faces' head states, best first) that could be the head's own
        face when that was found within ``FRESH_FACE_FRAMES`` frames: within a factor
        ``FACE_SIZE_CHANGE`` of its size, or within ``FACE_MATCH_DISTANCE`` of its widths of where
        it was (a face half out of the frame is found at other sizes); None when none could. The
        first when the head's face is not fresh. A face does not change size that much in a few
        frames: one of another size elsewhere is someone else's, or the detector's mistake while
        a hand hides this one (hand2: papers on the desk behind, 30 px against the face's 42,
        took the head away from its person for 56 frames)."""
        if not self.has_fresh_face:
            return 0
        own = FACE_ON_HEAD.state(self.last_face)
        ratios = states[:, 2] / own[2]
        alike = (ratios >= 1 / FACE_SIZE_CHANGE) & (ratios <= FACE_SIZE_CHANGE)
        near = np.hypot(*(states[:, :2] - own[:2]).T) <= FACE_MATCH_DISTANCE * self.last_face[2]
        could = np.flatnonzero(alike | near)
        return int(could[0]) if could.size else None

    def _own_region(self) -> BoxRelation:
        """The region whose colours are the target's after an automatic start: the template's
        reference region (the head's or the hand's box)."""
        return BoxRelation.of(self.template.reference_box, np.array([0.0, 0.0, 1.0, 0.0]))

    def _appearance_term(self, bins: np.ndarray | None) -> Appearance | None:
        """D² of states on this frame's colour ``bins``, once the target's appearance is known."""
        if bins is None or self.appearance is None:
            return None
        return partial(self.appearance.squared_distances, bins)

    def _may_switch(self, estimate: TrackEstimate | None) -> bool:
        """Whether a hypothesis could start the filter (when not, the search is skipped): not
        while the estimate's motion support is within ``switch_margin`` of 1, since no
        hypothesis's support exceeds 1, nor while the target a start box named holds."""
        if self.status != TRACKING or estimate is None:
            return True
        p = self.parameters
        holds = estimate.confidence >= p.lost_confidence and estimate.appearance_distance <= p.lost_appearance_distance
        if self.started_from_box and self.appearance is not None and holds:
            # A start box names the target: while its edges and colours hold, a region moving
            # more elsewhere (someone walking past, a waving hand) does not take over a still
            # person. people_crossing, the still head's box: 0.02 -> 1.00; no real sequence
            # changed (none switched from a box while its target held).
            return False
        return estimate.motion_support + p.switch_margin <= 1.0

    def _should_start(self, found: Hypothesis, estimate: TrackEstimate | None, moving: bool) -> bool:
        """Start on a hypothesis when there is no target, or when it is clearly better elsewhere
        (``moving``: whether the frame has a motion mask)."""
        p = self.parameters
        if moving and found.motion_support < p.init_motion_support:
            return False
        if found.skin_support < p.lost_skin_support or found.appearance_distance > p.lost_appearance_distance:
            return False  # it would be a weak frame at once
        if self.status != TRACKING or estimate is None:
            return found.confidence >= p.init_confidence
        far = np.hypot(*(found.state[:2] - estimate.state[:2])) > 0.5 * estimate.state[2]
        fits = found.confidence >= p.lost_confidence
        return far and fits and found.motion_support >= estimate.motion_support + p.switch_margin

    def _to_camera_factors(self) -> np.ndarray:
        """Per-component factors taking a state [x, y, s, θ] from working to camera pixels."""
        return np.array([1.0 / self.scale, 1.0 / self.scale, 1.0 / self.scale, 1.0])

    def working_width(self, frame_width: int) -> int:
        """The width frames ``frame_width`` pixels wide are reduced to for this track (0: none):
        ``working_width``, or wider for a target narrower than ``min_target_width`` there."""
        width = self.parameters.working_width
        if width <= 0 or self.finest_scale is None or working_scale(frame_width, width) >= self.finest_scale:
            return width
        needed = math.ceil(self.finest_scale * frame_width)
        return 0 if needed >= frame_width else needed

    def _fit_resolution(self, target_width: float, scale: float) -> None:
        """Keep a target ``target_width`` camera pixels wide (its scale s) at least
        ``min_target_width`` working pixels across from the next frame on, by a working frame
        finer than ``scale`` (working pixels per camera pixel), with a quarter more than
        needed, so that a target a little smaller next frame does not change the frame's size
        again. The frame stays that fine until the target is forgotten (:meth:`reset`): a
        contour's scale swings, and going back and forth lost the camera's motion, the face
        detector's run and the appearance's colours at each change."""
        least = self.parameters.min_target_width
        if least > 0 and target_width > 0 and least / target_width > scale:
            self.finest_scale = RESOLUTION_MARGIN * least / target_width

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
        if self.previous_frame is not None:
            # What earlier frames left in working pixels; no camera motion or face localisation
            # across frames of two sizes.
            if self.last_face is not None:
                self.last_face = tuple(v * ratio for v in self.last_face)  # type: ignore[assignment]
            if self.reported_state is not None:
                self.reported_state = self.reported_state * factors
            self.previous_frame = self.detected_on = None
            self._pending = None
        self.scale = scale
        self.filter.parameters = self.filter_parameters.scaled(scale)

    def _at_working(self, name: str, mask: np.ndarray | None, shape: tuple[int, int]) -> np.ndarray | None:
        """A cue mask of the frame ``shape``, at any resolution, brought to the working one."""
        if mask is None:
            return None
        working = working_shape(shape, self.working_width(shape[1]))
        if mask.shape == working:
            return mask
        if not same_frame(mask.shape, shape):
            raise ValueError(f'{name} {mask.shape} cannot be the image {shape} at any resolution')
        return cv2.resize(mask, (working[1], working[0]), interpolation=cv2.INTER_NEAREST)

    def _to_camera(self, estimate: TrackEstimate) -> TrackEstimate:
        """``estimate`` (working pixels) in camera pixels."""
        if self.scale == 1.0:
            return estimate
        factors = self._to_camera_factors()
        inverse = 1.0 / self.scale
        x, y, w, h = estimate.box
        return replace(
            estimate,
            state=estimate.state * factors,
            covariance=estimate.covariance * np.outer(factors, factors),
            box=(x * inverse, y * inverse, w * inverse, h * inverse),
            contour=estimate.contour * inverse,
            fit_residual=estimate.fit_residual * inverse,
            position_error=estimate.position_error * inverse,
            centre_covariance=estimate.centre_covariance * inverse**2,
        )


def _face_on(detections: list[Detection], state: np.ndarray) -> Detection | None:
    """The nearest of ``detections`` that is the face of the head at ``state`` (working pixels):
    within ``FACE_MATCH_DISTANCE`` face widths of where the contour puts the face, of about
    its size (within a factor ``FACE_MATCH_SIZE``). The nearest, not the likeliest: a face
    passing close by (someone walking in front) is not this head's."""
    x, y, size, height = FACE_ON_HEAD.box(state)
    centre = np.array([x + size / 2, y + height / 2])
    best, best_distance = None, FACE_MATCH_DISTANCE * size
    for detection in detections:
        distance = float(np.hypot(*(np.array(box_centre(detection.box)) - centre)))
        if distance <= best_distance and 1 / FACE_MATCH_SIZE <= detection.box[2] / size <= FACE_MATCH_SIZE:
            best, best_distance = detection, distance
    return best


def _moves_within(motion: np.ndarray, states: np.ndarray, reach: float, margin: float) -> bool:
    """Whether ``motion`` (non-zero on moving pixels) has a moving pixel within ``reach``
    template units of a state's position (times its scale) plus ``margin`` pixels, for some
    of the ``(P, 4)`` ``states``: the pixels their contours' motion support is counted on."""
    radius = reach * float(states[:, 2].max()) + margin
    left, top = (max(0, int(np.floor(v - radius))) for v in states[:, :2].min(axis=0))
    right, bottom = (max(0, int(np.ceil(v + radius)) + 1) for v in states[:, :2].max(axis=0))
    return bool(np.any(motion[top:bottom, left:right]))


def _cleared(mask: np.ndarray, boxes: Sequence[Box]) -> np.ndarray:
    """A copy of ``mask`` with zeros on ``boxes`` (x, y, w, h, its pixels)."""
    mask = mask.copy()
    for x, y, w, h in boxes:
        mask[max(0, int(y)) : max(0, int(y + h)), max(0, int(x)) : max(0, int(x + w))] = 0
    return mask


def _same_shape(previous: np.ndarray | None, current: np.ndarray) -> bool:
    return previous is not None and previous.shape == current.shape


def _face_and_neck(face: tuple[float, float, float, float]) -> tuple[float, float, float, float]:
    """The skin around a detected face box (x, y, w, h): the box runs from the eyebrows to the
    chin, and the forehead above it and the neck and collar down to 1.5 face heights below the
    chin are skin of the same region. Down to 0.8 face heights, a hand's contour settled on the
    chin and collar while the hand waved beside the face (hand2 as a person, 20 seeds: precision
    0.41 -> 0.46, the most confidently wrong frames of a run 9.0 % -> 6.4 %; the hand alone
    0.42 either way, but a restart can now fall on skin-coloured wood: docs/evaluation.md)."""
    x, y, w, h = face
    return (x - 0.2 * w, y - 0.3 * h, 1.4 * w, 2.8 * h)
