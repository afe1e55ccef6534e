"""The particle filter's constants (§2.2-2.5, §3.2), named in words with the paper's symbol."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from human_tracker.vision.checks import parameter

__all__ = ['TrackerParameters']


@dataclass
class TrackerParameters:
    """The filter's constants; names in words, the paper's symbol in brackets.

    Attributes:
        num_particles: P, number of particles: the most the filter uses.
        min_particles: The fewest particles the filter keeps after a frame: between it and
            ``num_particles``, the count is what the posterior's spread needs (KLD-sampling,
            :func:`~human_tracker.vision.filter.particle_filter.kld_resample`); ``num_particles`` or
            more: always ``num_particles``.
        kld_error: ε of KLD-sampling, the Kullback-Leibler divergence allowed between the
            particles' posterior and the true one.
        kld_confidence: 1-δ of KLD-sampling, the probability that the divergence stays below ε.
        kld_bin: KLD-sampling's grid cell: x, y and s as fractions of the estimate's scale s,
            θ in radians.
        search_halfwidth: δ in eq. 2, pixels searched each side of a point on its normal.
        miss_penalty: ρ in eqs. 2-3, cost of a point with no edge within δ.
        search_reference_scale: s_ref, pixels per template unit: a particle of scale s < s_ref
            searches δ s / s_ref and its distances count times s_ref / s, so that a contour
            shrunk into a face's inner features does not fit as well as the whole outline;
            0 (the default): δ and distances in pixels at every scale, as in the paper.
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
            (:mod:`~human_tracker.vision.cues.appearance`), used when the tracker is given one.
        min_scale: Smallest scale s (pixels per template unit: the reference region's width).
            A contour not much larger than its search band δ fits any edge blob, so the
            default is 2δ.
        max_scale: Largest scale s, pixels per template unit.
        importance_share: Share of the particles drawn around detections with the
            importance correction f / g when there are detections (ICONDENSATION,
            :mod:`~human_tracker.vision.filter.proposals`).
        restart_share: Share drawn around detections without correction.
        proposal_spread: Standard deviations of the particles drawn around a detection,
            same units as process_noise; also the width of a detection's likelihood term.
        detection_floor: Likelihood of a state far from every detection relative to one on a
            detection, on frames with detections
            (:func:`~human_tracker.vision.filter.proposals.detection_log_likelihood`); 1 leaves the
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

    num_particles: int = parameter(500, 'P, number of particles: the most the filter uses.', low=1, high=100000)
    min_particles: int = parameter(
        500,
        'Fewest particles kept; below num_particles the count follows the posterior (KLD-sampling).',
        low=1,
        high=100000,
    )
    kld_error: float = parameter(
        0.05, 'ε of KLD-sampling: the KL divergence allowed from the true posterior.', low=0.0001, high=0.99
    )
    kld_confidence: float = parameter(
        0.99, '1-δ of KLD-sampling: the probability the divergence stays below ε.', low=0.51, high=0.9999
    )
    kld_bin: tuple[float, float, float, float] = parameter(
        (0.1, 0.1, 0.05, 0.1), "KLD-sampling's bin: x, y, s as fractions of the scale s, θ (rad)."
    )
    search_halfwidth: float = parameter(
        12.0, 'δ (eq. 2): pixels searched each side of a contour point along its normal.', low=0.5, high=500.0
    )
    miss_penalty: float = parameter(
        144.0, 'ρ (eqs. 2-3): cost of a point with no edge within δ.', low=0.0, high=1000000000.0
    )
    search_reference_scale: float = parameter(
        0.0,
        'Scale (px) below which a contour searches δ in proportion and counts distances in its own size; 0: off.',
        low=0.0,
        high=1000000.0,
    )
    likelihood_gain: float = parameter(0.01, 'K (eq. 1): gain of the likelihood exp(-K Σ φ).', low=1e-09, high=1000.0)
    orientation_tolerance: float = parameter(
        0.5,
        'Largest angle (rad) between an edge gradient and the contour normal for the edge to count; π/2: every edge'
        ' (the paper).',
        low=0.01,
        high=1.5707963267948966,
    )
    interior_weight: float = parameter(
        2.0, 'w (§3.2, > 1): non-skin inside the contour costs 1/w of skin outside.', low=1.0001, high=1000000.0
    )
    colour_depth: float = parameter(
        0.1, 'How far inside / outside the contour skin is sampled, template units.', low=0.001, high=1.0
    )
    appearance_gain: float = parameter(
        40.0, 'λ of the appearance term exp(-λ D²) of the fused likelihood.', low=0.0, high=10000.0
    )
    velocity_damping: float = parameter(
        0.6, 'a of the AR(2) dynamics (§2.2): 0 random walk, 1 constant velocity.', low=0.0, high=1.0
    )
    process_noise: tuple[float, float, float, float] = parameter(
        (5.0, 5.0, 0.01, 0.02), 'W (§2.2): std of x, y (px), s (fraction), θ (rad) per frame.'
    )
    initial_spread: tuple[float, float, float, float] = parameter(
        (8.0, 8.0, 0.08, 0.08), 'Σ (§2.5): std of the initial cloud: x, y (px), s (fraction), θ (rad).'
    )
    min_scale: float = parameter(24.0, 'Smallest scale s: reference region width in pixels.', low=1.0, high=100000.0)
    max_scale: float = parameter(2000.0, 'Largest scale s: reference region width in pixels.', low=1.0, high=100000.0)
    importance_share: float = parameter(
        0.2, 'Share of particles drawn around detections with the f/g correction.', low=0.0, high=1.0
    )
    restart_share: float = parameter(
        0.05, 'Share of particles drawn around detections without correction.', low=0.0, high=1.0
    )
    proposal_spread: tuple[float, float, float, float] = parameter(
        (6.0, 6.0, 0.08, 0.05), 'Std of particles drawn around a detection: x, y (px), s (fraction), θ (rad).'
    )
    detection_floor: float = parameter(
        0.001, 'Likelihood of a state far from every face found, relative to one on a face.', low=1e-09, high=1.0
    )
    shape_switch: float = parameter(
        0.1, "Probability a frame that a particle changes to another of the template's shapes.", low=0.0, high=1.0
    )
    variant_penalty: float = parameter(
        8.0, "Cost of a particle in a variant shape (a closed hand), in ρ's.", low=0.0, high=1000.0
    )
    seed: int = parameter(
        0, 'Seed of the particle filter (replays are reproducible).', low=0, high=2147483647, runtime=False
    )

    def validate(self) -> None:
        """Raise ValueError naming the first parameter out of its range."""
        checks = [
            (self.num_particles >= 1, f'num_particles must be >= 1, got {self.num_particles}'),
            (self.min_particles >= 1, f'min_particles must be >= 1, got {self.min_particles}'),
            (0 < self.kld_error < 1, f'kld_error (ε) must be in (0, 1), got {self.kld_error}'),
            (0.5 < self.kld_confidence < 1, f'kld_confidence (1-δ) must be in (0.5, 1), got {self.kld_confidence}'),
            (
                len(self.kld_bin) == 4 and min(self.kld_bin) > 0,
                f'kld_bin must be 4 values > 0, got {self.kld_bin}',
            ),
            (self.search_halfwidth > 0, f'search_halfwidth (δ) must be > 0, got {self.search_halfwidth}'),
            (self.miss_penalty >= 0, f'miss_penalty (ρ) must be >= 0, got {self.miss_penalty}'),
            (
                self.search_reference_scale >= 0,
                f'search_reference_scale must be >= 0 (0: off), got {self.search_reference_scale}',
            ),
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

    @property
    def adaptive(self) -> bool:
        """Whether the particle count follows the posterior (KLD-sampling)."""
        return self.min_particles < self.num_particles

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
            search_reference_scale=self.search_reference_scale * factor,
            likelihood_gain=self.likelihood_gain / factor**2,
            process_noise=(x * factor, y * factor, s, theta),
            initial_spread=(sx * factor, sy * factor, ss, stheta),
            proposal_spread=(px * factor, py * factor, ps, ptheta),
            min_scale=self.min_scale * factor,
            max_scale=self.max_scale * factor,
        )
