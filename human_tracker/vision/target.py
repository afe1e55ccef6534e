"""Following one target: the contour tracker with motion cues, automatic (re)initialisation
and loss detection. This is what a node or the offline command runs per frame.

Per frame: the edge map is computed; a motion mask (foreground of the background model, or
optical-flow motion) enters the likelihood as eqs. 3-4 (``weighted``), or restricts the edges
to moving pixels (``mask``, the variant §2.4.2 shows to fail when the person stops).

The moving region's §2.5 estimate X_0 is a hypothesis, scored by the fraction of contour
points that find an edge (best over a small cloud around X_0). It starts the filter when the
filter has no target (WAITING, LOST) and the score reaches ``init_confidence``. It restarts
the filter elsewhere when its *moving* score (points whose edge lies on the motion mask)
beats the current estimate's by ``switch_margin`` while fitting at least ``lost_confidence``
of its points: the person came back, or the filter slid onto still clutter that fits the
template as well as the person does. The target is lost when, for ``lost_frames`` frames in
a row, fewer than ``lost_confidence`` of the points find an edge, or (with
``lost_motion_support`` > 0) fewer than that fraction lie on the motion mask. The second
test suits the background cue, where a person who stands still is still foreground; with
optical flow a still person does not move, so it stays off there. A lost target comes back
through a motion hypothesis when a mask is given (the filter's own fit on clutter is no
evidence of the person), and when the edges fit again when there is no mask.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import cv2
import numpy as np

from human_tracker.vision.initialisation import state_from_moments, state_from_scan
from human_tracker.vision.measurement import edge_map
from human_tracker.vision.particle_filter import gaussian_cloud
from human_tracker.vision.templates import ContourTemplate
from human_tracker.vision.tracker import ContourTracker, TrackerParameters, TrackEstimate

__all__ = ['INIT_METHODS', 'MOTION_MODES', 'Hypothesis', 'TargetParameters', 'TargetResult', 'TargetTracker']

MOTION_MODES = ('off', 'weighted', 'mask')
INIT_METHODS = ('scan', 'moments')

WAITING = 'WAITING'
TRACKING = 'TRACKING'
LOST = 'LOST'


@dataclass
class TargetParameters:
    """How cues are combined and when the target counts as lost.

    Attributes:
        motion_mode: ``off`` (eqs. 1-2), ``weighted`` (eqs. 3-4) or ``mask`` (edges on moving
            pixels only).
        init_method: ``scan`` (§2.5.2, head from the top of the moving region) or ``moments``
            (§2.5.1, blob moments; for a hand or a head alone).
        upright_angle: θ_upright of the scan initialisation, radians.
        min_blob_area: Smallest moving region, pixels, that can start or restart a track.
        region_closing: Radius (pixels) of the closing that joins a moving silhouette's parts
            before the region is measured (§2.5); 0 disables it.
        init_confidence: Score a motion hypothesis needs to start the filter, in [0, 1].
        switch_margin: How much better than the current estimate a hypothesis elsewhere must
            score to restart the filter there.
        hypothesis_samples: States drawn around X_0 (twice ``initial_spread``) to score it.
        lost_confidence: Fraction of contour points finding an edge below which a frame is weak.
        lost_motion_support: Fraction of contour points on the motion mask below which a
            frame with a mask is weak; 0 disables the test (use it with the foreground cue).
        lost_frames: Consecutive weak frames after which the target is lost.
        edge_blur_sigma: Gaussian pre-filter of the edge detector, pixels.
        canny_low: Canny low threshold.
        canny_high: Canny high threshold.
    """

    motion_mode: str = 'weighted'
    init_method: str = 'scan'
    upright_angle: float = 0.0
    min_blob_area: int = 1000
    region_closing: int = 4
    init_confidence: float = 0.45
    switch_margin: float = 0.2
    hypothesis_samples: int = 128
    lost_confidence: float = 0.3
    lost_motion_support: float = 0.0
    lost_frames: int = 5
    edge_blur_sigma: float = 1.5
    canny_low: float = 40.0
    canny_high: float = 100.0

    def validate(self) -> None:
        """Raise ValueError naming the first parameter out of its range."""
        if self.motion_mode not in MOTION_MODES:
            raise ValueError(f'motion_mode must be one of {", ".join(MOTION_MODES)}, got {self.motion_mode!r}')
        if self.init_method not in INIT_METHODS:
            raise ValueError(f'init_method must be one of {", ".join(INIT_METHODS)}, got {self.init_method!r}')
        if self.min_blob_area < 1:
            raise ValueError(f'min_blob_area must be >= 1, got {self.min_blob_area}')
        if not 0.0 <= self.init_confidence <= 1.0 or not 0.0 <= self.switch_margin <= 1.0:
            raise ValueError(
                f'init_confidence and switch_margin must be in [0, 1], got {self.init_confidence}, {self.switch_margin}'
            )
        if self.hypothesis_samples < 1:
            raise ValueError(f'hypothesis_samples must be >= 1, got {self.hypothesis_samples}')
        if not 0.0 <= self.lost_confidence <= 1.0 or not 0.0 <= self.lost_motion_support <= 1.0:
            raise ValueError(
                'lost_confidence and lost_motion_support must be in [0, 1], '
                f'got {self.lost_confidence}, {self.lost_motion_support}'
            )
        if self.lost_frames < 1:
            raise ValueError(f'lost_frames must be >= 1, got {self.lost_frames}')
        if self.canny_low < 0 or self.canny_high < self.canny_low:
            raise ValueError(f'need 0 <= canny_low <= canny_high, got {self.canny_low}, {self.canny_high}')


class Hypothesis(NamedTuple):
    """A candidate state from the moving region and how well it fits.

    Attributes:
        state: ``(4,)`` [x, y, s, θ].
        confidence: Fraction of contour points that found an edge.
        motion_support: Fraction of contour points whose edge moves.
    """

    state: np.ndarray
    confidence: float
    motion_support: float


@dataclass
class TargetResult:
    """One frame's outcome.

    Attributes:
        status: WAITING (never had a target), TRACKING, or LOST.
        estimate: The filter's estimate, None while WAITING.
        initialised: Whether the filter was (re)initialised on this frame.
    """

    status: str
    estimate: TrackEstimate | None
    initialised: bool = False

    @property
    def tracking(self) -> bool:
        """Whether a pose should be published for this frame."""
        return self.status == TRACKING and self.estimate is not None


@dataclass
class TargetTracker:
    """The contour particle filter plus motion cues, initialisation and loss detection."""

    template: ContourTemplate
    filter_parameters: TrackerParameters = field(default_factory=TrackerParameters)
    parameters: TargetParameters = field(default_factory=TargetParameters)
    status: str = WAITING
    weak_frames: int = 0
    filter: ContourTracker = field(init=False)

    def __post_init__(self) -> None:
        self.parameters.validate()
        self.filter = ContourTracker(self.template, self.filter_parameters)

    def initialise_from_box(self, box: tuple[float, float, float, float]) -> None:
        """Start on a known box (x, y, w, h) of the reference region (benchmark protocol)."""
        self.filter.initialise_from_box(box)
        self.status = TRACKING
        self.weak_frames = 0

    def mark_lost(self) -> None:
        """Declare the target lost (the next motion hypothesis may restart the filter)."""
        if self.status == TRACKING:
            self.status = LOST

    def reset(self) -> None:
        """Forget the target; wait for motion or a box."""
        self.filter.reset()
        self.status = WAITING
        self.weak_frames = 0

    def initial_state(self, motion: np.ndarray) -> np.ndarray | None:
        """X_0 from the moving region (§2.5), or None if there is no usable region."""
        p = self.parameters
        if p.region_closing:
            # Join the silhouette's moving parts into one region; the likelihood keeps the
            # tight mask so that still edges next to a moving person do not count as moving.
            motion = cv2.morphologyEx(
                motion, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * p.region_closing + 1,) * 2)
            )
        if p.init_method == 'moments':
            return state_from_moments(motion, self.template, p.min_blob_area)
        return state_from_scan(motion, self.template, upright_angle=p.upright_angle, min_area=p.min_blob_area)

    def hypothesis(self, motion: np.ndarray, edges: np.ndarray) -> Hypothesis | None:
        """The best-fitting state in a cloud around X_0 of the moving region, with its scores."""
        start = self.initial_state(motion)
        fp = self.filter.parameters
        if start is None or not fp.min_scale <= start[2] <= fp.max_scale:
            return None
        # Twice the initial spread: X_0 from a mask is coarse, the cloud must reach the silhouette.
        cloud = gaussian_cloud(
            start, 2.0 * np.asarray(fp.initial_spread), self.parameters.hypothesis_samples, self.filter.rng
        )
        cloud[0] = start
        np.clip(cloud[:, 2], fp.min_scale, fp.max_scale, out=cloud[:, 2])
        fit = self.filter.fit(edges, cloud, motion)
        best = int(np.argmax(fit.matched + fit.moving))
        n = self.template.num_points
        return Hypothesis(cloud[best], float(fit.matched[best]) / n, float(fit.moving[best]) / n)

    def process(self, gray: np.ndarray, motion: np.ndarray | None = None) -> TargetResult:
        """Track on one frame.

        Args:
            gray: ``(H, W) uint8`` intensity image.
            motion: Optional ``(H, W) uint8`` mask, non-zero on moving pixels (foreground or
                optical-flow motion) of the same frame.
        """
        p = self.parameters
        edges = edge_map(gray, blur_sigma=p.edge_blur_sigma, low_threshold=p.canny_low, high_threshold=p.canny_high)
        if motion is not None and motion.shape != gray.shape:
            raise ValueError(f'motion mask {motion.shape} does not match the image {gray.shape}')
        likelihood_motion = None
        if motion is not None and p.motion_mode == 'mask':
            edges = np.where(motion > 0, edges, 0).astype(np.uint8)
        elif motion is not None and p.motion_mode == 'weighted':
            likelihood_motion = motion
        estimate = self.filter.step(edges, likelihood_motion) if self.filter.initialised else None
        initialised = False
        found = self.hypothesis(motion, edges) if motion is not None else None
        if found is not None and self._should_start(found, estimate):
            self.filter.initialise(found.state)
            estimate = self.filter.step(edges, likelihood_motion)
            self.status, self.weak_frames, initialised = TRACKING, 0, True
        if estimate is None:
            return TargetResult(self.status, None)
        weak = estimate.confidence < p.lost_confidence
        if motion is not None and estimate.motion_support < p.lost_motion_support:
            weak = True
        self.weak_frames = self.weak_frames + 1 if weak else 0
        if self.weak_frames >= p.lost_frames:
            self.status = LOST
        elif self.weak_frames == 0 and self.status == LOST and motion is None:
            # Without a motion cue the edge fit is the only evidence; with one, a lost target
            # comes back only through a motion hypothesis (an edge fit on clutter is not the person).
            self.status = TRACKING
        return TargetResult(self.status, estimate, initialised)

    def _should_start(self, found: Hypothesis, estimate: TrackEstimate | None) -> bool:
        """Start on a hypothesis when there is no target, or when it is clearly better elsewhere."""
        p = self.parameters
        if self.status != TRACKING or estimate is None:
            return found.confidence >= p.init_confidence
        far = np.hypot(*(found.state[:2] - estimate.state[:2])) > 0.5 * estimate.state[2]
        fits = found.confidence >= p.lost_confidence
        return far and fits and found.motion_support >= estimate.motion_support + p.switch_margin
