"""Detector proposals: ICONDENSATION (Isard & Blake, ECCV 1998), as the paper's authors used it
with face detections (Brèthes, Lerasle, Danès, Fontmarty, MVA 2010).

When there are detections, the P particles of a frame come from three sources:

- ``1 - importance_share - restart_share`` of them from the dynamics of §2.2 (the prior
  ``f(x) = Σ_j w_j p(x | x_j)``), with no correction;
- ``importance_share`` from the importance function ``g(x)``, an equal mixture of Gaussians
  around the detections' states, each weighted by the correction ``f(x) / g(x)`` so that the
  filter still estimates the same posterior;
- ``restart_share`` from ``g`` with no correction: the re-initialisation component, which lets
  a detection pull a filter back from clutter its prior no longer reaches.

The corrections enter the log weights beside the likelihood. Particles drawn from ``g`` have
no past: their previous state is their current one (zero velocity in the AR(2) model).

A face detection is also a measurement (:func:`detection_log_likelihood`): on a frame where the
detector found faces, a state's likelihood is multiplied by how close its position and scale
are to a detection's, above a floor for a state near none (the detection may be a false one,
or another person's face). Without it a contour that slid onto part of the head (a half-head
on strong inner edges: hair, glasses) outscores the particles drawn at the face it came from.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ['detection_log_likelihood', 'draw_with_proposals', 'log_prior_density', 'log_proposal_density']


@numba.njit(cache=True, nogil=True)
def _log_mixture(states: np.ndarray, means: np.ndarray, stds: np.ndarray, log_weights: np.ndarray) -> np.ndarray:
    """``(R,)`` log of the mixture Σ_m w_m N(states_r; means_m, diag(stds_m²)) of ``(R, 4)``
    states, ``(M, 4)`` means and stds, and ``(M,)`` log w_m (the log-sum-exp taken per state)."""
    count = means.shape[0]
    norms = np.empty(count)
    for m in range(count):
        norms[m] = log_weights[m] - np.sum(np.log(stds[m])) - 2.0 * np.log(2.0 * np.pi)
    terms = np.empty(count)
    out = np.empty(states.shape[0])
    for r in range(states.shape[0]):
        best = -np.inf
        for m in range(count):
            squared = 0.0
            for k in range(4):
                z = (states[r, k] - means[m, k]) / stds[m, k]
                squared += z * z
            terms[m] = norms[m] - 0.5 * squared
            best = max(best, terms[m])
        total = 0.0
        for m in range(count):
            total += np.exp(terms[m] - best)
        out[r] = best + np.log(total)
    return out


def _stds(states: np.ndarray, spread: np.ndarray) -> np.ndarray:
    """Per-state standard deviations: x, y, θ as given, s as a fraction of the state's scale."""
    stds = np.broadcast_to(np.asarray(spread, dtype=np.float64), states.shape).copy()
    stds[:, 2] *= states[:, 2]
    return np.maximum(stds, 1e-9)


def log_prior_density(
    states: np.ndarray,
    current: np.ndarray,
    previous: np.ndarray,
    velocity_damping: float,
    process_noise: np.ndarray,
) -> np.ndarray:
    """``(R,)`` log f(x) of the AR(2) prior from an equally weighted (resampled) particle set.

    Args:
        states: ``(R, 4)`` where to evaluate f.
        current: ``(P, 4)`` particles x_{k-1}.
        previous: ``(P, 4)`` the same particles at k-2.
        velocity_damping: a of §2.2.
        process_noise: ``(4,)`` W's standard deviations (s as a fraction of the scale).
    """
    # Resampling copies particles next to each other: each run of copies is one component,
    # weighted by its length (the same density, evaluated a few times faster).
    pairs = np.hstack([current, previous])
    first = np.flatnonzero(np.concatenate([[True], np.any(pairs[1:] != pairs[:-1], axis=1)]))
    copies = np.diff(np.append(first, len(pairs)))
    current, previous = current[first], previous[first]
    means = current + velocity_damping * (current - previous)
    log_weights = np.log(copies / copies.sum())
    return _log_mixture(np.asarray(states, dtype=np.float64), means, _stds(current, process_noise), log_weights)


def log_proposal_density(states: np.ndarray, detections: np.ndarray, spread: np.ndarray) -> np.ndarray:
    """``(R,)`` log g(x): an equal mixture of Gaussians of ``spread`` around ``detections`` ``(D, 4)``."""
    log_weights = np.full(len(detections), -np.log(len(detections)))
    return _log_mixture(np.asarray(states, dtype=np.float64), detections, _stds(detections, spread), log_weights)


def draw_with_proposals(
    current: np.ndarray,
    previous: np.ndarray,
    predicted: np.ndarray,
    detections: np.ndarray,
    *,
    velocity_damping: float,
    process_noise: np.ndarray,
    spread: np.ndarray,
    importance_share: float,
    restart_share: float,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Replace shares of the predicted particles with draws around the detections.

    Args:
        current: ``(P, 4)`` particles before prediction (x_{k-1}), equally weighted.
        previous: ``(P, 4)`` the same at k-2.
        predicted: ``(P, 4)`` their prediction through the dynamics (x_k).
        detections: ``(D, 4)`` states of the detections, D >= 1.
        velocity_damping, process_noise: The dynamics that made ``predicted``.
        spread: ``(4,)`` standard deviations of g around a detection (s as a fraction).
        importance_share: Share of particles drawn from g with the correction f / g.
        restart_share: Share drawn from g without correction.
        rng: Seeded generator.

    Returns:
        ``(particles, previous, log_correction)``: the new x_k ``(P, 4)``, their x_{k-1}, and
        ``(P,)`` log correction terms to add to the log likelihood.
    """
    count = len(predicted)
    importance = int(round(importance_share * count))
    restart = int(round(restart_share * count))
    drawn_count = min(count, importance + restart)
    particles = predicted.copy()
    past = current.copy()
    correction = np.zeros(count)
    if drawn_count == 0:
        return particles, past, correction
    which = rng.integers(0, len(detections), size=drawn_count)
    centres = detections[which]
    drawn = centres + rng.standard_normal((drawn_count, 4)) * _stds(centres, spread)
    np.maximum(drawn[:, 2], 1e-3, out=drawn[:, 2])
    # The last particles are replaced: after systematic resampling their order carries no meaning.
    slots = np.arange(count - drawn_count, count)
    particles[slots] = drawn
    past[slots] = drawn
    corrected = slots[:importance]
    correction[corrected] = log_prior_density(
        drawn[:importance], current, previous, velocity_damping, process_noise
    ) - log_proposal_density(drawn[:importance], detections, spread)
    return particles, past, correction


def detection_log_likelihood(
    states: np.ndarray, detections: np.ndarray, spread: np.ndarray, floor: float
) -> np.ndarray:
    """``(R,)`` log of ``floor + (1 - floor) max_m exp(-z_m² / 2)``: how well each state agrees with a detection.

    Args:
        states: ``(R, 4)`` states [x, y, s, θ].
        detections: ``(D, 4)`` states of the detections, D >= 1.
        spread: ``(4,)`` standard deviations around a detection (s as a fraction of the
            detection's scale); θ is left out of z: a face box says nothing of the head's tilt.
        floor: Relative likelihood of a state far from every detection, in (0, 1]; 1 makes
            the term constant.
    """
    stds = _stds(np.asarray(detections, dtype=np.float64), spread)[:, :3]
    z = (np.asarray(states, dtype=np.float64)[:, None, :3] - detections[None, :, :3]) / stds[None]
    nearest = np.min(np.sum(z * z, axis=2), axis=1)
    return np.log(floor + (1.0 - floor) * np.exp(-0.5 * nearest))
