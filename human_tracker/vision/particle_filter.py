"""Particle-filter bookkeeping (§2.1): initial cloud, resampling and the state estimate."""

from __future__ import annotations

import numpy as np

__all__ = [
    'gaussian_cloud',
    'systematic_resample',
    'effective_sample_size',
    'weighted_estimate',
    'weighted_covariance',
]


def gaussian_cloud(
    mean: np.ndarray,
    std: np.ndarray,
    count: int,
    rng: np.random.Generator,
) -> np.ndarray:
    """Draw ``count`` states from N(X_0, Σ) with diagonal Σ (§2.5).

    Args:
        mean: ``(4,)`` initial estimate X_0 = [x, y, s, θ].
        std: ``(4,)`` standard deviations: x, y pixels; s as a fraction of X_0's scale;
            θ radians.
        count: Number of particles P.
        rng: Seeded generator.

    Returns:
        ``(P, 4) float64`` particles.
    """
    std = np.asarray(std, dtype=np.float64).copy()
    std[2] *= mean[2]
    cloud = mean + rng.standard_normal((count, 4)) * std
    np.maximum(cloud[:, 2], 1e-3, out=cloud[:, 2])
    return cloud


def systematic_resample(weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Indices of the particles kept by systematic resampling (one uniform draw).

    Args:
        weights: ``(P,)`` normalised weights.
        rng: Seeded generator.

    Returns:
        ``(P,) int64`` indices into the particle set, sorted.
    """
    count = weights.shape[0]
    positions = (rng.random() + np.arange(count)) / count
    cumulative = np.cumsum(weights)
    cumulative[-1] = 1.0  # guard against round-off leaving the last position unmatched
    return np.searchsorted(cumulative, positions, side='left').astype(np.int64)


def effective_sample_size(weights: np.ndarray) -> float:
    """``1 / Σ w_i²``: P for uniform weights, 1 when one particle holds all the weight."""
    return float(1.0 / np.sum(np.square(weights)))


def weighted_estimate(particles: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Weighted mean state; θ is averaged on the circle so ±π does not cancel out."""
    estimate = weights @ particles
    estimate[3] = np.arctan2(weights @ np.sin(particles[:, 3]), weights @ np.cos(particles[:, 3]))
    return estimate


def weighted_covariance(samples: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``(D, D)`` weighted covariance of ``(P, D)`` samples."""
    mean = weights @ samples
    centred = samples - mean
    return (centred * weights[:, None]).T @ centred
