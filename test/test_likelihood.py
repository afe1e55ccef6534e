"""The particles' weights as a sum of likelihood terms, and a new cue added as a field and a term."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from human_tracker.vision.cues.evidence import Evidence
from human_tracker.vision.filter.contour_filter import ContourTracker, TrackerParameters
from human_tracker.vision.filter.likelihood import (
    TERMS,
    Observation,
    TermValue,
    appearance_term,
    colour_term,
    contour_term,
    weigh,
)
from human_tracker.vision.filter.measurement import log_likelihood
from human_tracker.vision.filter.templates import hand, head_and_shoulders
from human_tracker.vision.track.target import TargetParameters, TargetTracker


def _scene(seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random edges, motion and skin labels, 120x160."""
    rng = np.random.default_rng(seed)
    edges = (rng.random((120, 160)) < 0.08).astype(np.uint8) * 255
    motion = (rng.random((120, 160)) < 0.3).astype(np.uint8) * 255
    skin = (rng.random((120, 160)) < 0.4).astype(np.uint8) * 255
    return edges, motion, skin


def test_the_terms_sum_to_the_paper_likelihood_with_colour() -> None:
    """Eq. 1 over eqs. 2-4 and §3.2: the contour and colour terms together give -K Σ (φ + ρ γ_colour),
    the log weight of the fit's total cost; a cue that is missing adds nothing."""
    filter = ContourTracker(hand(), TrackerParameters(seed=0))  # open and closed: a variant shape
    edges, motion, skin = _scene()
    states = np.array([[80.0, 60.0, 40.0, 0.0], [70.0, 65.0, 30.0, 0.2], [90.0, 55.0, 50.0, -0.1]])
    labels = np.array([0, 1, 0])
    observation = Observation(edges, motion, skin)
    log, measures = weigh(filter, TERMS, states, labels, observation)
    expected = log_likelihood(filter.fit(edges, states, motion, skin, labels).costs, filter.parameters.likelihood_gain)
    np.testing.assert_allclose(log, expected, rtol=1e-12)
    assert set(measures) == {'costs', 'matched', 'moving', 'squared_distances', 'skin'}
    assert colour_term(filter, states, labels, Observation(edges, motion)).log_weights is None
    assert appearance_term(filter, states, labels, observation).log_weights is None
    without_colour, _ = weigh(filter, TERMS, states, labels, Observation(edges, motion))
    np.testing.assert_array_equal(without_colour, contour_term(filter, states, labels, observation).log_weights)


@dataclass(frozen=True)
class _WithBeacon(Evidence):
    """A toy cue: a point the person carries (x, y, camera pixels), a field of the evidence."""

    beacon: tuple[float, float] = (0.0, 0.0)


def _beacon_term(filter: ContourTracker, particles: np.ndarray, labels, observation: Observation) -> TermValue:
    """-d²/2σ², σ 10 camera pixels, d from the beacon to the particle's position."""
    x, y = (v * observation.scale for v in observation.evidence.beacon)
    squared = (particles[:, 0] - x) ** 2 + (particles[:, 1] - y) ** 2
    return TermValue(-squared / (2.0 * (10.0 * observation.scale) ** 2), {})


def test_a_new_cue_is_a_field_and_a_term_without_touching_the_orchestrator() -> None:
    """On blank 640x480 frames (no edge: the contour term is flat) a track started from a box stays
    put; with the toy beacon's term in its filter's terms, the same track is drawn to the beacon,
    120 px to the right, and the camera-pixel estimate ends on it."""
    image = np.full((480, 640, 3), 128, np.uint8)
    box = (200.0, 150.0, 80.0, 80.0)
    beacon = (360.0, 190.0)
    ends = {}
    for with_term in (False, True):
        tracker = TargetTracker(head_and_shoulders(), TrackerParameters(seed=0), TargetParameters(proposals='off'))
        if with_term:
            tracker.filter.terms = (*tracker.filter.terms, _beacon_term)
        tracker.initialise_from_box(box)
        start = None
        for _ in range(40):
            result = tracker.step(_WithBeacon(image, beacon=beacon))
            start = start if start is not None else result.estimate.state[:2].copy()
        ends[with_term] = result.estimate.state[:2]
    assert np.hypot(*(ends[False] - start)) < 40.0
    assert np.hypot(*(ends[True] - np.array(beacon))) < 10.0
