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
template as well as the person does. The target is lost when, for ``lost_frames`` frames in
a row, fewer than ``lost_confidence`` of the points find an edge, or (with
``lost_motion_support`` > 0) fewer than that fraction lie on the motion mask. The second
test suits the background cue, where a person who stands still is still foreground; with
optical flow a still person does not move, so it stays off there. A lost target comes back
through a motion hypothesis when a mask is given (the filter's own fit on clutter is no
evidence of the person), and when the edges fit again when there is no mask.

Skin labels (§3.2) enter in one of the paper's two ways (``colour_mode``): the colour term
γ_colour in the likelihood (``weighted``), or as the area the template is fitted in
(``mask``: edges only near skin). They can also delimit the region X_0 comes from
(``init_region``): for a hand, skin regions, so that moving clothes do not start the
filter (the template's fit tells the hand from the face and skin-coloured things).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import NamedTuple

import cv2
import numpy as np

from human_tracker.vision.initialisation import blobs, moments_state, state_from_scan
from human_tracker.vision.measurement import edge_map
from human_tracker.vision.morphology import disk
from human_tracker.vision.particle_filter import gaussian_cloud
from human_tracker.vision.resolution import same_frame, to_working, working_scale, working_shape
from human_tracker.vision.templates import ContourTemplate
from human_tracker.vision.tracker import ContourTracker, TrackerParameters, TrackEstimate, state_from_box

__all__ = [
    'COLOUR_MODES',
    'INIT_METHODS',
    'INIT_REGIONS',
    'MOTION_MODES',
    'Hypothesis',
    'TargetParameters',
    'TargetResult',
    'TargetTracker',
    'parameters_for',
]

MOTION_MODES = ('off', 'weighted', 'mask')
COLOUR_MODES = ('off', 'weighted', 'mask')
INIT_METHODS = ('scan', 'moments')
INIT_REGIONS = ('motion', 'skin')

WAITING = 'WAITING'
TRACKING = 'TRACKING'
LOST = 'LOST'


@dataclass
class TargetParameters:
    """How cues are combined and when the target counts as lost.

    Attributes:
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
        upright_angle: θ_upright of the scan initialisation, radians.
        min_blob_area: Smallest moving region, pixels, that can start or restart a track.
        region_closing: Radius (pixels) of the closing that joins a moving silhouette's parts
            before the region is measured (§2.5); 0 disables it.
        init_confidence: Score a motion hypothesis needs to start the filter, in [0, 1].
        switch_margin: How much better than the current estimate a hypothesis elsewhere must
            score to restart the filter there.
        hypothesis_samples: States drawn around X_0 (twice ``initial_spread``) to score it.
        hypothesis_blobs: With ``moments``, how many of the largest regions each give an X_0
            (the best-fitting one wins: the hand among the skin-coloured regions).
        lost_confidence: Fraction of contour points finding an edge below which a frame is weak.
        lost_motion_support: Fraction of contour points on the motion mask below which a
            frame with a mask is weak; 0 disables the test (use it with the foreground cue).
        lost_skin_support: Share of the contour's interior on skin below which a frame with
            skin labels is weak (a hand that left the view leaves the contour on the room),
            and below which a hypothesis does not start the filter; 0 disables the test.
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
    """

    motion_mode: str = 'weighted'
    max_motion_fraction: float = 0.5
    colour_mode: str = 'weighted'
    skin_margin: int = 4
    init_region: str = 'motion'
    init_method: str = 'scan'
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
    lost_frames: int = 5
    colour_edges: bool = False
    edge_blur_sigma: float = 1.5
    canny_low: float = 40.0
    canny_high: float = 100.0
    working_width: int = 320

    def validate(self) -> None:
        """Raise ValueError naming the first parameter out of its range."""
        choices = {
            'motion_mode': MOTION_MODES,
            'colour_mode': COLOUR_MODES,
            'init_method': INIT_METHODS,
            'init_region': INIT_REGIONS,
        }
        for name, allowed in choices.items():
            if getattr(self, name) not in allowed:
                raise ValueError(f'{name} must be one of {", ".join(allowed)}, got {getattr(self, name)!r}')
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
        for name in ('lost_confidence', 'lost_motion_support', 'lost_skin_support'):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f'{name} must be in [0, 1], got {getattr(self, name)}')
        if self.lost_frames < 1:
            raise ValueError(f'lost_frames must be >= 1, got {self.lost_frames}')
        if self.canny_low < 0 or self.canny_high < self.canny_low:
            raise ValueError(f'need 0 <= canny_low <= canny_high, got {self.canny_low}, {self.canny_high}')
        if self.working_width < 0:
            raise ValueError(f'working_width must be >= 0 (0: full size), got {self.working_width}')

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
    often as bright as what is behind it, but rarely the same colour.
    """
    if target == 'hand':
        # No switching while a hand is tracked: it stops and starts waving, and a swaying
        # face or sleeve then moves more. A hand that leaves takes the skin from inside the
        # contour, so it is lost, and found again among the skin regions when it comes back.
        return TargetParameters(
            init_method='moments',
            init_region='skin',
            hypothesis_blobs=3,
            switch_margin=1.0,
            lost_skin_support=0.7,
            colour_edges=True,
        )
    return TargetParameters()


class Hypothesis(NamedTuple):
    """A candidate state from the moving region and how well it fits.

    Attributes:
        state: ``(4,)`` [x, y, s, θ] in working pixels (what ``filter`` is initialised with).
        confidence: Fraction of contour points that found an edge.
        motion_support: Fraction of contour points whose edge moves.
        skin_support: Share of the contour's interior on skin (1 without skin labels).
    """

    state: np.ndarray
    confidence: float
    motion_support: float
    skin_support: float = 1.0


@dataclass
class TargetResult:
    """One frame's outcome.

    Attributes:
        status: WAITING (never had a target), TRACKING, or LOST.
        estimate: The filter's estimate, None while WAITING.
        initialised: Whether the filter was (re)initialised on this frame.
        motion_set_aside: Whether the frame's motion mask covered more than
            ``max_motion_fraction`` of it and was not used.
    """

    status: str
    estimate: TrackEstimate | None
    initialised: bool = False
    motion_set_aside: bool = False

    @property
    def tracking(self) -> bool:
        """Whether a pose should be published for this frame."""
        return self.status == TRACKING and self.estimate is not None


@dataclass
class TargetTracker:
    """The contour particle filter plus motion cues, initialisation and loss detection.

    Frames, boxes, estimates and parameters are in the camera's pixels; the filter itself
    (``filter``) works at the working resolution, ``scale`` working pixels per camera pixel.
    """

    template: ContourTemplate
    filter_parameters: TrackerParameters = field(default_factory=TrackerParameters)
    parameters: TargetParameters = field(default_factory=TargetParameters)
    status: str = WAITING
    weak_frames: int = 0
    filter: ContourTracker = field(init=False)
    scale: float = field(default=1.0, init=False)

    def __post_init__(self) -> None:
        self.parameters.validate()
        self.filter = ContourTracker(self.template, self.filter_parameters)

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

    def initialise_from_box(self, box: tuple[float, float, float, float]) -> None:
        """Start on a known box (x, y, w, h), camera pixels, of the reference region (benchmark protocol)."""
        self.filter.initialise(state_from_box(box, self.template) / self._to_camera_factors())
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

    def initial_region(self, motion: np.ndarray | None, skin: np.ndarray | None) -> np.ndarray | None:
        """The mask X_0 is computed from (``init_region``), or None without the cues it needs."""
        if self.parameters.init_region == 'skin' and skin is not None:
            return skin
        return motion if motion is not None else skin

    def initial_states(self, region: np.ndarray) -> list[np.ndarray]:
        """Candidate X_0 from a region mask (§2.5) at the working resolution; empty if there is no usable region."""
        p = self.parameters.scaled(self.scale)
        if p.region_closing:
            # Join the silhouette's moving parts into one region; the likelihood keeps the
            # tight mask so that still edges next to a moving person do not count as moving.
            region = cv2.morphologyEx(region, cv2.MORPH_CLOSE, disk(p.region_closing))
        if p.init_method == 'moments':
            return [moments_state(b, self.template) for b in blobs(region, p.min_blob_area, p.hypothesis_blobs)]
        start = state_from_scan(region, self.template, upright_angle=p.upright_angle, min_area=p.min_blob_area)
        return [] if start is None else [start]

    def hypothesis(
        self,
        region: np.ndarray,
        edges: np.ndarray,
        motion: np.ndarray | None = None,
        skin: np.ndarray | None = None,
    ) -> Hypothesis | None:
        """The best-fitting state in clouds around the X_0 of ``region``, with its scores."""
        fp = self.filter.parameters
        best: tuple[float, Hypothesis] | None = None
        n = self.template.num_points
        for start in self.initial_states(region):
            if not fp.min_scale <= start[2] <= fp.max_scale:
                continue
            # Twice the initial spread: X_0 from a mask is coarse, the cloud must reach the silhouette.
            cloud = gaussian_cloud(
                start, 2.0 * np.asarray(fp.initial_spread), self.parameters.hypothesis_samples, self.filter.rng
            )
            cloud[0] = start
            np.clip(cloud[:, 2], fp.min_scale, fp.max_scale, out=cloud[:, 2])
            fit = self.filter.fit(edges, cloud, motion, skin)
            # With colour the likelihood itself ranks the states; edges alone would favour
            # small contours that fit any clutter, so they rank by points on (moving) edges.
            score = -fit.costs if skin is not None else fit.matched + fit.moving - 1e-6 * fit.costs
            k = int(np.argmax(score))
            if best is None or score[k] > best[0]:
                skin_support = 1.0 if fit.skin is None else float(fit.skin[k])
                hypothesis = Hypothesis(cloud[k], float(fit.matched[k]) / n, float(fit.moving[k]) / n, skin_support)
                best = (float(score[k]), hypothesis)
        return None if best is None else best[1]

    def process(
        self, image: np.ndarray, motion: np.ndarray | None = None, skin: np.ndarray | None = None
    ) -> TargetResult:
        """Track on one frame.

        Args:
            image: ``(H, W) uint8`` intensity image, or ``(H, W, 3) uint8`` BGR image.
            motion: Optional ``uint8`` mask, non-zero on moving pixels (foreground or
                optical-flow motion) of the same frame, at any resolution of it (a cue stage
                publishes at its own working width); it is brought to the working size.
            skin: Optional ``uint8`` skin labels of the same frame, likewise.

        Returns:
            The outcome, its estimate in the camera's pixels.
        """
        self._rescale(working_scale(image.shape[1], self.parameters.working_width))
        p = self.parameters.scaled(self.scale)
        motion = self._at_working('motion mask', motion, image.shape[:2])
        set_aside = motion is not None and int(np.count_nonzero(motion)) > p.max_motion_fraction * motion.size
        if set_aside:
            motion = None
        skin = self._at_working('skin labels', skin, image.shape[:2])
        if image.ndim == 3 and not p.colour_edges:
            image = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        image = to_working(image, p.working_width)
        edges = edge_map(image, blur_sigma=p.edge_blur_sigma, low_threshold=p.canny_low, high_threshold=p.canny_high)
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
        estimate = self.filter.step(edges, likelihood_motion, likelihood_skin) if self.filter.initialised else None
        initialised = False
        region = self.initial_region(motion, skin)
        found = None
        if region is not None and self._may_switch(estimate):
            found = self.hypothesis(region, edges, motion, likelihood_skin)
        if found is not None and self._should_start(found, estimate):
            self.filter.initialise(found.state)
            estimate = self.filter.step(edges, likelihood_motion, likelihood_skin)
            self.status, self.weak_frames, initialised = TRACKING, 0, True
        if estimate is None:
            return TargetResult(self.status, None, motion_set_aside=set_aside)
        estimate = self._to_camera(estimate)
        weak = estimate.confidence < p.lost_confidence
        if motion is not None and estimate.motion_support < p.lost_motion_support:
            weak = True
        if likelihood_skin is not None and estimate.skin_support < p.lost_skin_support:
            weak = True
        self.weak_frames = self.weak_frames + 1 if weak else 0
        if self.weak_frames >= p.lost_frames:
            self.status = LOST
        elif self.weak_frames == 0 and self.status == LOST and region is None:
            # Without a region cue the edge fit is the only evidence; with one, a lost target
            # comes back only through a hypothesis (an edge fit on clutter is not the person).
            self.status = TRACKING
        return TargetResult(self.status, estimate, initialised, set_aside)

    def _may_switch(self, estimate: TrackEstimate | None) -> bool:
        """Whether a hypothesis could start the filter: not while the estimate's motion support is
        within ``switch_margin`` of 1, since no hypothesis's support exceeds 1 (the search is skipped)."""
        if self.status != TRACKING or estimate is None:
            return True
        return estimate.motion_support + self.parameters.switch_margin <= 1.0

    def _should_start(self, found: Hypothesis, estimate: TrackEstimate | None) -> bool:
        """Start on a hypothesis when there is no target, or when it is clearly better elsewhere."""
        p = self.parameters
        if found.skin_support < p.lost_skin_support:
            return False  # it would be a weak frame at once
        if self.status != TRACKING or estimate is None:
            return found.confidence >= p.init_confidence
        far = np.hypot(*(found.state[:2] - estimate.state[:2])) > 0.5 * estimate.state[2]
        fits = found.confidence >= p.lost_confidence
        return far and fits and found.motion_support >= estimate.motion_support + p.switch_margin

    def _to_camera_factors(self) -> np.ndarray:
        """Per-component factors taking a state [x, y, s, θ] from working to camera pixels."""
        return np.array([1.0 / self.scale, 1.0 / self.scale, 1.0 / self.scale, 1.0])

    def _rescale(self, scale: float) -> None:
        """Work at ``scale`` working pixels per camera pixel (first frame, or a new frame size)."""
        if scale == self.scale:
            return
        if self.filter.particles is not None and self.filter.previous is not None:
            factors = self._to_camera_factors() * np.array([scale, scale, scale, 1.0])
            self.filter.particles = self.filter.particles * factors
            self.filter.previous = self.filter.previous * factors
        self.scale = scale
        self.filter.parameters = self.filter_parameters.scaled(scale)

    def _at_working(self, name: str, mask: np.ndarray | None, shape: tuple[int, int]) -> np.ndarray | None:
        """A cue mask of the frame ``shape``, at any resolution, brought to the working one."""
        if mask is None:
            return None
        working = working_shape(shape, self.parameters.working_width)
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
        )
