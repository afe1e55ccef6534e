"""The contour tracker: one predict-weigh-resample cycle of §2 per frame."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from human_tracker.vision.camera_motion import move_states
from human_tracker.vision.dynamics import predict
from human_tracker.vision.measurement import (
    ContourFit,
    colour_costs,
    contour_costs,
    log_likelihood,
    normalised_weights,
)
from human_tracker.vision.particle_filter import (
    effective_sample_size,
    gaussian_cloud,
    systematic_resample,
    weighted_covariance,
    weighted_estimate,
)
from human_tracker.vision.proposals import detection_log_likelihood, draw_with_proposals
from human_tracker.vision.templates import ContourTemplate, reference_centres, transform_points

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
class TrackerParameters:
    """The filter's constants; names in words, the paper's symbol in brackets.

    Attributes:
        num_particles: P, number of particles.
        search_halfwidth: δ in eq. 2, pixels searched each side of a point on its normal.
        miss_penalty: ρ in eqs. 2-3, cost of a point with no edge within δ.
        likelihood_gain: K in eq. 1.
        orientation_tolerance: Largest angle (radians) between an edge's gradient and the
            contour normal for the edge to count as z(j); π/2 accepts any edge (the paper).
        velocity_damping: a in the AR(2) matrix A (§2.2), in [0, 1].
        process_noise: W of §2.2: std of x, y (pixels), s (fraction), θ (radians).
        initial_spread: diagonal of Σ of §2.5, same units as process_noise.
        interior_weight: w of the colour term (§3.2), > 1: how much less a non-skin pixel
            inside the contour costs than a skin pixel outside.
        colour_depth: How far inside and outside the contour the skin labels are sampled,
            template units (a fraction of the reference region's width).
        appearance_gain: λ of the appearance term exp(-λ D²)
            (:mod:`~human_tracker.vision.appearance`), used when the tracker is given one.
        min_scale: Smallest scale s (pixels per template unit: the reference region's width).
            A contour not much larger than its search band δ fits any edge blob, so the
            default is 2δ.
        max_scale: Largest scale s, pixels per template unit.
        importance_share: Share of the particles drawn around detections with the
            importance correction f / g when there are detections (ICONDENSATION,
            :mod:`~human_tracker.vision.proposals`).
        restart_share: Share drawn around detections without correction.
        proposal_spread: Standard deviations of the particles drawn around a detection,
            same units as process_noise; also the width of a detection's likelihood term.
        detection_floor: Likelihood of a state far from every detection relative to one on a
            detection, on frames with detections
            (:func:`~human_tracker.vision.proposals.detection_log_likelihood`); 1 leaves the
            detections out of the likelihood (they then only draw particles).
        shape_switch: With a template of several shapes (a hand open or closed), the
            probability that a particle changes shape from one frame to the next, to another
            shape drawn at random: the mixed state's transition.
        variant_penalty: Cost of a particle drawn in one of the template's variants rather
            than in the template itself, in missed points (times ρ): where both fit, the
            template wins. A closed hand is a rounder, simpler outline than the open one and
            fits skin-coloured blobs the open hand does not.
        seed: Seed of the filter's random generator (a replay is then reproducible).
    """

    num_particles: int = 500
    search_halfwidth: float = 12.0
    miss_penalty: float = 144.0
    likelihood_gain: float = 0.01
    orientation_tolerance: float = 0.5
    interior_weight: float = 2.0
    colour_depth: float = 0.1
    appearance_gain: float = 40.0
    velocity_damping: float = 0.6
    process_noise: tuple[float, float, float, float] = (5.0, 5.0, 0.01, 0.02)
    initial_spread: tuple[float, float, float, float] = (8.0, 8.0, 0.08, 0.08)
    min_scale: float = 24.0
    max_scale: float = 2000.0
    importance_share: float = 0.2
    restart_share: float = 0.05
    proposal_spread: tuple[float, float, float, float] = (6.0, 6.0, 0.08, 0.05)
    detection_floor: float = 0.001
    shape_switch: float = 0.1
    variant_penalty: float = 8.0
    seed: int = 0

    def validate(self) -> None:
        """Raise ValueError naming the first parameter out of its range."""
        checks = [
            (self.num_particles >= 1, f'num_particles must be >= 1, got {self.num_particles}'),
            (self.search_halfwidth > 0, f'search_halfwidth (δ) must be > 0, got {self.search_halfwidth}'),
            (self.miss_penalty >= 0, f'miss_penalty (ρ) must be >= 0, got {self.miss_penalty}'),
            (
                0 < self.orientation_tolerance <= np.pi / 2,
                f'orientation_tolerance must be in (0, π/2], got {self.orientation_tolerance}',
            ),
            (self.interior_weight > 1, f'interior_weight (w) must be > 1, got {self.interior_weight}'),
            (0 < self.colour_depth <= 1, f'colour_depth must be in (0, 1], got {self.colour_depth}'),
            (self.likelihood_gain > 0, f'likelihood_gain (K) must be > 0, got {self.likelihood_gain}'),
            (self.appearance_gain >= 0, f'appearance_gain (λ) must be >= 0, got {self.appearance_gain}'),
            (
                0 < self.min_scale <= self.max_scale,
                f'need 0 < min_scale <= max_scale, got {self.min_scale}, {self.max_scale}',
            ),
            (0.0 <= self.velocity_damping <= 1.0, f'velocity_damping must be in [0, 1], got {self.velocity_damping}'),
            (
                len(self.process_noise) == 4 and min(self.process_noise) >= 0,
                f'process_noise must be 4 values >= 0, got {self.process_noise}',
            ),
            (
                len(self.initial_spread) == 4 and min(self.initial_spread) >= 0,
                f'initial_spread must be 4 values >= 0, got {self.initial_spread}',
            ),
            (
                len(self.proposal_spread) == 4 and min(self.proposal_spread) > 0,
                f'proposal_spread must be 4 values > 0, got {self.proposal_spread}',
            ),
            (0.0 < self.detection_floor <= 1.0, f'detection_floor must be in (0, 1], got {self.detection_floor}'),
            (0.0 <= self.shape_switch <= 1.0, f'shape_switch must be in [0, 1], got {self.shape_switch}'),
            (self.variant_penalty >= 0, f'variant_penalty must be >= 0, got {self.variant_penalty}'),
            (
                min(self.importance_share, self.restart_share) >= 0 and self.importance_share + self.restart_share <= 1,
                f'importance_share and restart_share must be >= 0 with a sum <= 1, got '
                f'{self.importance_share}, {self.restart_share}',
            ),
        ]
        for ok, message in checks:
            if not ok:
                raise ValueError(message)

    def scaled(self, factor: float) -> TrackerParameters:
        """The same filter on images resized by ``factor``: pixel lengths times ``factor``.

        ρ and the costs are squared distances, so ρ scales by ``factor²`` and K by its
        inverse: the likelihood of a state is then the same at every resolution.
        """
        if factor == 1.0:
            return self
        x, y, s, theta = self.process_noise
        sx, sy, ss, stheta = self.initial_spread
        px, py, ps, ptheta = self.proposal_spread
        return replace(
            self,
            search_halfwidth=self.search_halfwidth * factor,
            miss_penalty=self.miss_penalty * factor**2,
            likelihood_gain=self.likelihood_gain / factor**2,
            process_noise=(x * factor, y * factor, s, theta),
            initial_spread=(sx * factor, sy * factor, ss, stheta),
            proposal_spread=(px * factor, py * factor, ps, ptheta),
            min_scale=self.min_scale * factor,
            max_scale=self.max_scale * factor,
        )


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

    The fields are the filter's whole state; ``step`` runs §2.2 (predict), §2.3-2.4 (weigh)
    and resampling on one frame. With a template of several shapes each particle also carries
    its shape (``labels``), which changes with probability ``shape_switch`` a frame.
    """

    template: ContourTemplate
    parameters: TrackerParameters = field(default_factory=TrackerParameters)
    particles: np.ndarray | None = None
    previous: np.ndarray | None = None
    labels: np.ndarray | None = None
    rng: np.random.Generator = field(init=False)
    _points: np.ndarray = field(init=False, repr=False)
    _normals: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.parameters.validate()
        self.rng = np.random.default_rng(self.parameters.seed)
        self._points = np.stack([shape.points for shape in self.template.shapes])
        self._normals = np.stack([shape.normals for shape in self.template.shapes])

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
        (``(2, 3)`` similarity, :mod:`~human_tracker.vision.camera_motion`) before the next
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
    ) -> TrackEstimate:
        """Predict, weigh against ``edges`` (and ``motion``, ``skin``, ``appearance``), estimate, resample.

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

        Returns:
            The estimate for this frame.

        Raises:
            RuntimeError: The tracker was not initialised.
        """
        if self.particles is None or self.previous is None or self.labels is None:
            raise RuntimeError('ContourTracker.step called before initialise')
        params = self.parameters
        if self.particles.shape[0] != params.num_particles:
            self._resize(params.num_particles)
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
        fit = self.fit(edges, self.particles, motion, skin, self.labels)
        distances = None if appearance is None else appearance(self.particles)
        log_weights = self.log_weights(fit, distances)
        if correction is not None:
            log_weights += correction
            floor = params.detection_floor if detection_floor is None else detection_floor
            if floor < 1.0:
                log_weights += detection_log_likelihood(
                    self.particles, np.asarray(detections, dtype=np.float64), np.asarray(params.proposal_spread), floor
                )
        weights = normalised_weights(log_weights)
        state = weighted_estimate(self.particles, weights)
        residual = _fit_residual(fit, weights, params.search_halfwidth)
        position_error = float(np.sqrt(max(residual**2 - RESIDUAL_FLOOR**2, 0.0) + 1.0 / 12.0))
        centres = reference_centres(self.particles, self.template)
        shapes = self.template.shapes
        shape = shapes[int(np.argmax(np.bincount(self.labels, weights, len(shapes))))]
        estimate = TrackEstimate(
            state=state,
            covariance=weighted_covariance(self.particles, weights),
            confidence=float(weights @ fit.matched) / self.template.num_points,
            motion_support=float(weights @ fit.moving) / self.template.num_points,
            skin_support=0.0 if fit.skin is None else float(weights @ fit.skin),
            appearance_distance=0.0 if distances is None else float(np.sqrt(weights @ distances)),
            fit_residual=residual,
            position_error=position_error,
            centre_covariance=weighted_covariance(centres, weights) + position_error**2 * np.eye(2),
            effective_sample_size=effective_sample_size(weights),
            box=box_from_state(state, self.template),
            contour=transform_points(shape.points, state),
            shape=shape.name,
        )
        keep = systematic_resample(weights, self.rng)
        self.particles = self.particles[keep]
        self.previous = self.previous[keep]
        self.labels = self.labels[keep]
        return estimate

    def log_weights(self, fit: ContourFit, appearance_distances: np.ndarray | None = None) -> np.ndarray:
        """Unnormalised log weights: -K Σ φ (eq. 1), minus λ D² with an appearance term."""
        log = log_likelihood(fit.costs, self.parameters.likelihood_gain)
        if appearance_distances is not None:
            log = log - self.parameters.appearance_gain * appearance_distances
        return log

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
        params = self.parameters
        fit = contour_costs(
            edges,
            states,
            self._points,
            self._normals,
            search_halfwidth=params.search_halfwidth,
            miss_penalty=params.miss_penalty,
            motion=motion,
            orientation_tolerance=params.orientation_tolerance,
            labels=labels,
        )
        if labels is not None and params.variant_penalty:
            fit = fit._replace(costs=fit.costs + params.variant_penalty * params.miss_penalty * (labels > 0))
        if skin is None:
            return fit
        colour, interior_skin = colour_costs(
            skin,
            states,
            self._points,
            self._normals,
            interior_weight=params.interior_weight,
            depth=params.colour_depth,
            labels=labels,
        )
        return fit._replace(costs=fit.costs + params.miss_penalty * colour, skin=interior_skin)

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


def _fit_residual(fit: ContourFit, weights: np.ndarray, search_halfwidth: float) -> float:
    """:attr:`TrackEstimate.fit_residual` of ``fit`` over the particles' ``weights``."""
    found = float(weights @ fit.matched)
    if found < 1.0:
        return float(search_halfwidth)
    return float(np.sqrt(float(weights @ fit.squared_distances) / found))
