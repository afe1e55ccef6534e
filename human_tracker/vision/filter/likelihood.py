"""The particles' weights: a sum of log-likelihood terms, one per cue.

The observation model is a product of independent cues, p(z | x) = Π_k p_k(z_k | x), so a
particle's log weight is a sum of terms. Each term is a function of the filter (its template
and constants), the particles ``(P, 4)`` and their shapes ``(P,)``, and the frame's
:class:`Observation`; it returns the log weights it adds and what it measured (by name, one
value per particle), which the estimate reports. The terms of :data:`TERMS`:

- :func:`contour_term`, eqs. 1-4: -K Σ_j φ(j), the contour's fit to the edges along its normals,
  with motion (γ of eq. 4 is read at the edge point z(j), so motion is part of this term), plus
  ``variant_penalty`` ρ for a particle in one of the template's variant shapes;
- :func:`colour_term`, §3.2: -K ρ Σ_j γ_colour(j), the skin labels inside and outside the contour;
- :func:`appearance_term`: -λ D², the Bhattacharyya distance of the contour's region from the
  target's learnt colours (:mod:`~human_tracker.vision.cues.appearance`);
- :func:`detection_term`: the log of ``floor + (1 - floor) exp(-z²/2)`` around the nearest
  detection (:func:`~human_tracker.vision.filter.proposals.detection_log_likelihood`).

A term whose cue is missing on a frame (no skin labels, no appearance yet, no detection)
adds nothing. A new cue is a new field of the :class:`~human_tracker.vision.cues.evidence.Evidence`
(:attr:`Observation.evidence`) and a new term in the filter's ``terms``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple, Protocol

import numpy as np

from human_tracker.vision.filter.measurement import colour_costs, contour_costs, log_likelihood
from human_tracker.vision.filter.parameters import TrackerParameters
from human_tracker.vision.filter.proposals import detection_log_likelihood

__all__ = [
    'TERMS',
    'ContourModel',
    'LikelihoodTerm',
    'Observation',
    'TermValue',
    'appearance_term',
    'colour_term',
    'contour_term',
    'detection_term',
    'weigh',
]

# The squared Bhattacharyya distance D² of each state ``(P, 4)``: ``(P,)``.
Appearance = Callable[[np.ndarray], np.ndarray]


class Observation(NamedTuple):
    """What the terms read of one frame, at the filter's resolution.

    Attributes:
        edges: ``(H, W) uint8`` edge map (non-zero on edges).
        motion: ``(H, W) uint8`` motion mask of eqs. 3-4, or None.
        skin: ``(H, W) uint8`` skin labels of §3.2, or None.
        appearance: D² of states on this frame, or None while the target's colours are unknown.
        detections: ``(D, 4)`` states of this frame's detections, or None.
        detection_floor: The detection term's floor (1: the term is constant).
        evidence: The whole frame's evidence (camera pixels), for terms of other cues; None.
        scale: The filter's pixels per camera pixel (to read ``evidence`` at the particles).
    """

    edges: np.ndarray
    motion: np.ndarray | None = None
    skin: np.ndarray | None = None
    appearance: Appearance | None = None
    detections: np.ndarray | None = None
    detection_floor: float = 1.0
    evidence: Any = None
    scale: float = 1.0


class TermValue(NamedTuple):
    """A term's contribution: ``(P,)`` log weights (None: nothing on this frame) and what it
    measured, by name, ``(P,)`` each."""

    log_weights: np.ndarray | None
    measures: dict[str, np.ndarray]


class ContourModel(Protocol):
    """What a term reads of the filter it weighs for: its constants and the contour's measurement
    points and normals (template units, ``(N, 2)`` each)."""

    parameters: TrackerParameters
    points: np.ndarray
    normals: np.ndarray


LikelihoodTerm = Callable[[ContourModel, np.ndarray, np.ndarray | None, Observation], TermValue]
"""A term: (filter, particles ``(P, 4)``, shapes ``(P,)`` or None, observation) -> its value."""


def contour_term(
    filter: ContourModel, particles: np.ndarray, labels: np.ndarray | None, observation: Observation
) -> TermValue:
    """Eqs. 1-4: -K Σ_j φ(j) of the contour along its normals, with motion; a particle in a
    variant shape pays ``variant_penalty`` ρ more. Measures ``matched`` and ``moving`` points
    and ``squared_distances`` (Σ d(j)² over the matched points)."""
    p = filter.parameters
    fit = contour_costs(
        observation.edges,
        particles,
        filter.points,
        filter.normals,
        search_halfwidth=p.search_halfwidth,
        miss_penalty=p.miss_penalty,
        motion=observation.motion,
        orientation_tolerance=p.orientation_tolerance,
        labels=labels,
        reference_scale=p.search_reference_scale,
    )
    costs = fit.costs
    if labels is not None and p.variant_penalty:
        costs = costs + p.variant_penalty * p.miss_penalty * (labels > 0)
    measures = {
        'costs': costs,
        'matched': fit.matched,
        'moving': fit.moving,
        'squared_distances': fit.squared_distances,
    }
    return TermValue(log_likelihood(costs, p.likelihood_gain), measures)


def colour_term(
    filter: ContourModel, particles: np.ndarray, labels: np.ndarray | None, observation: Observation
) -> TermValue:
    """§3.2: -K ρ Σ_j γ_colour(j), skin labels sampled inside (weighed by 1/w) and outside the
    contour along its normals. Measures ``skin``, the share of the interior samples on skin."""
    if observation.skin is None:
        return TermValue(None, {})
    p = filter.parameters
    colour, interior_skin = colour_costs(
        observation.skin,
        particles,
        filter.points,
        filter.normals,
        interior_weight=p.interior_weight,
        depth=p.colour_depth,
        labels=labels,
    )
    costs = p.miss_penalty * colour
    return TermValue(log_likelihood(costs, p.likelihood_gain), {'costs': costs, 'skin': interior_skin})


def appearance_term(
    filter: ContourModel, particles: np.ndarray, labels: np.ndarray | None, observation: Observation
) -> TermValue:
    """-λ D²: the colours of the contour's region against the target's (``appearance_gain`` λ).
    Measures ``appearance_distances`` (D²)."""
    if observation.appearance is None:
        return TermValue(None, {})
    distances = observation.appearance(particles)
    return TermValue(-filter.parameters.appearance_gain * distances, {'appearance_distances': distances})


def detection_term(
    filter: ContourModel, particles: np.ndarray, labels: np.ndarray | None, observation: Observation
) -> TermValue:
    """The detections' term, around the nearest one (``proposal_spread`` wide)."""
    if observation.detections is None or not len(observation.detections) or observation.detection_floor >= 1.0:
        return TermValue(None, {})
    spread = np.asarray(filter.parameters.proposal_spread)
    log = detection_log_likelihood(particles, observation.detections, spread, observation.detection_floor)
    return TermValue(log, {})


TERMS: tuple[LikelihoodTerm, ...] = (contour_term, colour_term, appearance_term, detection_term)
"""The filter's terms by default."""


def weigh(
    filter: ContourModel,
    terms: tuple[LikelihoodTerm, ...],
    particles: np.ndarray,
    labels: np.ndarray | None,
    observation: Observation,
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The unnormalised log weights ``(P,)``: the sum of the ``terms``; and what they measured
    (a name measured by two terms: the last one's, but ``costs``: their sum, Σ φ of the fit)."""
    log_weights = np.zeros(particles.shape[0])
    measures: dict[str, np.ndarray] = {}
    for term in terms:
        value = term(filter, particles, labels, observation)
        if value.log_weights is not None:
            log_weights = log_weights + value.log_weights
        for name, measured in value.measures.items():
            measures[name] = measures[name] + measured if name == 'costs' and name in measures else measured
    return log_weights, measures
