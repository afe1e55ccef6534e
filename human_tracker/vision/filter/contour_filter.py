"""The contour tracker: one predict-weigh-resample cycle of §2 per frame."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from human_tracker.vision.filter.dynamics import move_states, predict
from human_tracker.vision.filter.likelihood import TERMS, LikelihoodTerm, Observation, colour_term, contour_term, weigh
from human_tracker.vision.filter.measurement import ContourFit, normalised_weights
from human_tracker.vision.filter.parameters import TrackerParameters
from human_tracker.vision.filter.particle_filter import (
    effective_sample_size,
    gaussian_cloud,
    kld_resample,
    systematic_resample,
    weighted_covariance,
    weighted_estimate,
)
from human_tracker.vision.filter.proposals import draw_with_proposals
from human_tracker.vision.filter.templates import ContourTemplate, reference_centres, transform_points

__all__ = [
    'RESIDUAL_FLOOR',
    'TrackerParameters',
    'TrackEstimate',
    'ContourTracker',
    'state_from_box',
    'box_from_state',
]

RESIDUAL_FLOOR = 1.2
"""Fit residual (pixels of the image the filter measures) of a contour lying on the person's
outline: its points find edges on the pixel grid, on a silhouette that is not exactly the
template. Only the residual above it is the contour's position error
(:attr:`TrackEstimate.position_error`); the bags' sharp outlines give residuals of 1.4-1.8."""


@dataclass
class TrackEstimate:
    """What the tracker knows after one frame.

    Attributes:
        state: ``(4,)`` weighted mean [x, y, s, θ] (pixels, pixels/unit, radians).
        covariance: ``(4, 4)`` weighted covariance of the particle cloud.
        confidence: Weighted fraction of measurement points that found an edge, in [0, 1].
        motion_support: Weighted fraction of points whose edge moves (0 without motion).
        effective_sample_size: 1 / Σ w² before resampling, in [1, P].
        box: ``(x, y, w, h)`` pixels, bounding box of the template's reference region.
        contour: ``(N, 2)`` image points of the template at ``state``, in ``shape``.
        skin_support: Weighted share of the contour's interior samples on skin (0 without skin).
        appearance_distance: Bhattacharyya distance D of the target's region from its
            reference, sqrt of the weighted mean D² (0 without an appearance model).
        fit_residual: Root mean square distance, pixels, from the contour's points to the
            edges they found along their normals (eq. 2's d(j)), over the weighted particles;
            δ when no point found one. How far the contour sits from the person: the pose's
            covariance grows with it.
        position_error: Standard deviation, pixels, of the contour's own position error along
            each image axis: the fit residual above :data:`RESIDUAL_FLOOR` (in quadrature),
            plus the pixel grid's 1/12 px² variance.
        centre_covariance: ``(2, 2)`` covariance (pixels²) of the reference region's centre:
            the weighted particles' spread plus ``position_error``² on each axis.
        shape: Name of the template's shape holding most of the weight (a hand: ``open_hand``
            or ``closed_hand``).
        particle_count: Particles weighed on this frame.
    """

    state: np.ndarray
    covariance: np.ndarray
    confidence: float
    motion_support: float
    effective_sample_size: float
    box: tuple[float, float, float, float]
    contour: np.ndarray
    skin_support: float = 0.0
    appearance_distance: float = 0.0
    fit_residual: float = 0.0
    position_error: float = 0.0
    centre_covariance: np.ndarray = field(default_factory=lambda: np.zeros((2, 2)))
    shape: str = ''
    particle_count: int = 0

    def scaled(self, factor: float) -> TrackEstimate:
        """The same estimate on images resized by ``factor``: lengths (and s) times ``factor``."""
        if factor == 1.0:
            return self
        lengths = np.array([factor, factor, factor, 1.0])  # x, y, s, θ
        x, y, w, h = self.box
        return replace(
            self,
            state=self.state * lengths,
            covariance=self.covariance * np.outer(lengths, lengths),
            box=(x * factor, y * factor, w * factor, h * factor),
            contour=self.contour * factor,
            fit_residual=self.fit_residual * factor,
            position_error=self.position_error * factor,
            centre_covariance=self.centre_covariance * factor**2,
        )


# An appearance term: the squared Bhattacharyya distance D² of each state ``(P, 4)``, ``(P,)``.
Appearance = Callable[[np.ndarray], np.ndarray]


def state_from_box(box: tuple[float, float, float, float], template: ContourTemplate) -> np.ndarray:
    """State [x, y, s, 0] whose reference region fills ``box`` = (x, y, w, h) pixels."""
    bx, by, bw, bh = (float(v) for v in box)
    if bw <= 0 or bh <= 0:
        raise ValueError(f'box width and height must be > 0, got {box}')
    rx, ry, rw, rh = template.reference_box
    scale = 0.5 * (bw / rw + bh / rh)
    cx = bx + bw / 2 - scale * (rx + rw / 2)
    cy = by + bh / 2 - scale * (ry + rh / 2)
    return np.array([cx, cy, scale, 0.0])


def check_box_in_image(box: tuple[float, float, float, float], shape: tuple[int, ...]) -> None:
    """Raise ValueError unless the centre of ``box`` = (x, y, w, h) lies in an image of ``shape`` (H, W, ...).

    A box partly outside the image is taken (a person at the frame's edge): the filter starts
    from the box's centre and size. The message of a refused box says where its centre lies.
    """
    x, y, w, h = (float(v) for v in box)
    height, width = shape[:2]
    cx, cy = x + w / 2, y + h / 2
    if 0 <= cx < width and 0 <= cy < height:
        return
    sides = [
        side
        for side, out in (
            ('left of x=0', cx < 0),
            (f'right of x={width}', cx >= width),
            ('above y=0', cy < 0),
            (f'below y={height}', cy >= height),
        )
        if out
    ]
    whole = x + w <= 0 or x >= width or y + h <= 0 or y >= height
    part = 'no part of the box is in it' if whole else 'part of the box is in it, but the filter starts from the centre'
    raise ValueError(
        f'the box {x:g},{y:g},{w:g},{h:g} has its centre ({cx:g}, {cy:g}) {" and ".join(sides)}: outside the '
        f'{width}x{height} image ({part})'
    )


def box_from_state(state: np.ndarray, template: ContourTemplate) -> tuple[float, float, float, float]:
    """Axis-aligned bounding box (x, y, w, h) in pixels of the rotated reference region."""
    rx, ry, rw, rh = template.reference_box
    corners = np.array([[rx, ry], [rx + rw, ry], [rx + rw, ry + rh], [rx, ry + rh]])
    image = transform_points(corners, state)
    lo = image.min(axis=0)
    hi = image.max(axis=0)
    return float(lo[0]), float(lo[1]), float(hi[0] - lo[0]), float(hi[1] - lo[1])


@dataclass
class ContourTracker:
    """Particle filter over [x, y, s, θ] fitting a contour template to image edges.

    The fields are the filter's whole state; ``step`` runs §2.2 (predict), §2.3-2.4 (weigh, by
    the sum of the likelihood ``terms``) and resampling on one frame. With a template of
    several shapes each particle also carries its shape (``labels``), which changes with
    probability ``shape_switch`` a frame.
    """

    template: ContourTemplate
    parameters: TrackerParameters = field(default_factory=TrackerParameters)
    particles: np.ndarray | None = None
    previous: np.ndarray | None = None
    labels: np.ndarray | None = None
    terms: tuple[LikelihoodTerm, ...] = TERMS
    rng: np.random.Generator = field(init=False)
    # Every shape's measurement points and normals, ``(K, N, 2)``, template units.
    points: np.ndarray = field(init=False, repr=False)
    normals: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.parameters.validate()
        self.rng = np.random.default_rng(self.parameters.seed)
        self.points = np.stack([shape.points for shape in self.template.shapes])
        self.normals = np.stack([shape.normals for shape in self.template.shapes])

    @property
    def initialised(self) -> bool:
        """Whether the filter has a particle cloud."""
        return self.particles is not None

    def initialise(self, state: np.ndarray) -> None:
        """Spread the particles around X_0 = ``state`` with covariance Σ (§2.5)."""
        self.particles = gaussian_cloud(
            np.asarray(state, dtype=np.float64),
            np.asarray(self.parameters.initial_spread),
            self.parameters.num_particles,
            self.rng,
        )
        self.previous = self.particles.copy()
        self.labels = self._draw_labels(self.parameters.num_particles)

    def initialise_from_box(self, box: tuple[float, float, float, float]) -> None:
        """Initialise on the reference region (head or hand) filling ``box`` (x, y, w, h)."""
        self.initialise(state_from_box(box, self.template))

    def follow_camera(self, transform: np.ndarray) -> None:
        """Carry the particles and their previous states with the camera's image motion
        (``(2, 3)`` similarity, :mod:`~human_tracker.vision.cues.camera_motion`) before the next
        step, so that the AR(2) velocity is the target's own motion, not the camera's."""
        if self.particles is None or self.previous is None:
            return
        self.particles = move_states(self.particles, transform)
        self.previous = move_states(self.previous, transform)

    def reset(self) -> None:
        """Forget the target; the next ``initialise`` starts afresh with the same seed."""
        self.particles = None
        self.previous = None
        self.labels = None
        self.rng = np.random.default_rng(self.parameters.seed)

    def step(
        self,
        edges: np.ndarray,
        motion: np.ndarray | None = None,
        skin: np.ndarray | None = None,
        appearance: Appearance | None = None,
        detections: np.ndarray | None = None,
        detection_spread: np.ndarray | None = None,
        restart_share: float | None = None,
        detection_floor: float | None = None,
        evidence: Any = None,
        scale: float = 1.0,
    ) -> TrackEstimate:
        """Predict, weigh by the filter's ``terms`` (:mod:`~human_tracker.vision.filter.likelihood`), estimate,
        resample.

        Args:
            edges: ``(H, W) uint8`` edge map (non-zero on edges).
            motion: Optional ``(H, W) uint8`` motion mask for eqs. 3-4.
            skin: Optional ``(H, W) uint8`` skin labels for the colour term of §3.2.
            appearance: Optional D² of each state; its term exp(-λ D²) multiplies the
                shape likelihood.
            detections: Optional ``(D, 4)`` states of detections: shares of the particles
                are drawn around them (ICONDENSATION).
            detection_spread: ``(4,)`` standard deviations of those draws, as
                ``proposal_spread`` (its value when None).
            restart_share: Share drawn without correction (``restart_share`` when None).
            detection_floor: The detections' likelihood term's floor (``detection_floor``
                when None; 1: the detections only draw particles).
            evidence: The frame's whole evidence, for terms of other cues
                (:attr:`~human_tracker.vision.filter.likelihood.Observation.evidence`).
            scale: This filter's pixels per camera pixel (``evidence``'s).

        Returns:
            The estimate for this frame.

        Raises:
            RuntimeError: The tracker was not initialised.
        """
        if self.particles is None or self.previous is None or self.labels is None:
            raise RuntimeError('ContourTracker.step called before initialise')
        params = self.parameters
        least = min(params.min_particles, params.num_particles)
        if not least <= self.particles.shape[0] <= params.num_particles:  # the bounds changed
            self._resize(min(max(self.particles.shape[0], least), params.num_particles))
        current, past = self.particles, self.previous
        self.particles, self.previous = predict(
            current, past, params.velocity_damping, np.asarray(params.process_noise), self.rng
        )
        self.labels = self._switch_shapes(self.labels)
        correction = None
        if detections is not None and len(detections):
            self.particles, self.previous, correction = draw_with_proposals(
                current,
                past,
                self.particles,
                np.asarray(detections, dtype=np.float64),
                velocity_damping=params.velocity_damping,
                process_noise=np.asarray(params.process_noise),
                spread=np.asarray(params.proposal_spread if detection_spread is None else detection_spread),
                importance_share=params.importance_share,
                restart_share=params.restart_share if restart_share is None else restart_share,
                rng=self.rng,
            )
        np.clip(self.particles[:, 2], params.min_scale, params.max_scale, out=self.particles[:, 2])
        floor = params.detection_floor if detection_floor is None else detection_floor
        found = None if detections is None else np.asarray(detections, dtype=np.float64)
        observation = Observation(edges, motion, skin, appearance, found, floor, evidence, scale)
        log_weights, measures = weigh(self, self.terms, self.particles, self.labels, observation)
        if correction is not None:
            log_weights += correction
        weights = normalised_weights(log_weights)
        state = weighted_estimate(self.particles, weights)
        matched, moving = measures['matched'], measures['moving']
        residual = _fit_residual(matched, measures['squared_distances'], weights, params.search_halfwidth)
        position_error = float(np.sqrt(max(residual**2 - RESIDUAL_FLOOR**2, 0.0) + 1.0 / 12.0))
        centres = reference_centres(self.particles, self.template)
        shapes = self.template.shapes
        shape = shapes[int(np.argmax(np.bincount(self.labels, weights, len(shapes))))]
        skin_share, distances = measures.get('skin'), measures.get('appearance_distances')
        estimate = TrackEstimate(
            state=state,
            covariance=weighted_covariance(self.particles, weights),
            confidence=float(weights @ matched) / self.template.num_points,
            motion_support=float(weights @ moving) / self.template.num_points,
            skin_support=0.0 if skin_share is None else float(weights @ skin_share),
            appearance_distance=0.0 if distances is None else float(np.sqrt(weights @ distances)),
            fit_residual=residual,
            position_error=position_error,
            centre_covariance=weighted_covariance(centres, weights) + position_error**2 * np.eye(2),
            effective_sample_size=effective_sample_size(weights),
            box=box_from_state(state, self.template),
            contour=transform_points(shape.points, state),
            shape=shape.name,
            particle_count=int(self.particles.shape[0]),
        )
        if params.adaptive:
            bins = np.array(params.kld_bin) * np.array([state[2], state[2], state[2], 1.0])
            bounds = (params.min_particles, params.num_particles)
            error, confidence = params.kld_error, params.kld_confidence
            keep = kld_resample(self.particles, weights, bins, bounds, error, confidence, self.rng)
        else:
            keep = systematic_resample(weights, self.rng)
        self.particles = self.particles[keep]
        self.previous = self.previous[keep]
        self.labels = self.labels[keep]
        return estimate

    def fit(
        self,
        edges: np.ndarray,
        states: np.ndarray,
        motion: np.ndarray | None = None,
        skin: np.ndarray | None = None,
        labels: np.ndarray | None = None,
    ) -> ContourFit:
        """How the template fits the image at ``states`` ``(P, 4)``: eqs. 2-4, plus ρ γ_colour (§3.2) with skin.

        ``labels`` ``(P,)``: the shape drawn at each state (its variants cost
        ``variant_penalty`` ρ more); without them, each state is measured in the shape that
        fits it best.
        """
        shapes = len(self.template.shapes)
        if labels is None and shapes > 1:
            # Every state in every shape in one pass of the kernels, then each state's best.
            count = len(states)
            fit = self.fit(edges, np.tile(states, (shapes, 1)), motion, skin, np.repeat(np.arange(shapes), count))
            best = np.argmin(fit.costs.reshape(shapes, count), axis=0)
            return ContourFit(
                *(None if values is None else values.reshape(shapes, count)[best, np.arange(count)] for values in fit)
            )
        observation = Observation(edges, motion, skin)
        contour = contour_term(self, states, labels, observation).measures
        colour = colour_term(self, states, labels, observation).measures
        costs = contour['costs'] + colour['costs'] if colour else contour['costs']
        return ContourFit(
            costs, contour['matched'], contour['moving'], contour['squared_distances'], colour.get('skin')
        )

    def _draw_labels(self, count: int) -> np.ndarray:
        """Shapes of a new cloud of ``count`` particles: each shape equally likely."""
        shapes = len(self.template.shapes)
        if shapes == 1:  # one shape draws nothing, so a one-shape filter's random stream stays the same
            return np.zeros(count, dtype=np.int64)
        return self.rng.integers(0, shapes, size=count)

    def _switch_shapes(self, labels: np.ndarray) -> np.ndarray:
        """The mixed state's transition: each particle changes shape with probability
        ``shape_switch``, to one of the others at random."""
        shapes = len(self.template.shapes)
        if shapes == 1:
            return labels
        switch = self.rng.random(labels.shape[0]) < self.parameters.shape_switch
        return np.where(switch, (labels + self.rng.integers(1, shapes, size=labels.shape[0])) % shapes, labels)

    def _resize(self, count: int) -> None:
        """Change the particle count at run time by resampling the current cloud uniformly."""
        assert self.particles is not None and self.previous is not None and self.labels is not None
        keep = self.rng.integers(0, self.particles.shape[0], size=count)
        self.particles = self.particles[keep]
        self.previous = self.previous[keep]
        self.labels = self.labels[keep]


def _fit_residual(
    matched: np.ndarray, squared_distances: np.ndarray, weights: np.ndarray, search_halfwidth: float
) -> float:
    """:attr:`TrackEstimate.fit_residual` of the points ``matched`` and their ``squared_distances``
    over the particles' ``weights``."""
    found = float(weights @ matched)
    if found < 1.0:
        return float(search_halfwidth)
    return float(np.sqrt(float(weights @ squared_distances) / found))
