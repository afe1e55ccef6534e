"""Particle-filter bookkeeping (§2.1): initial cloud, resampling, the sample size and the state estimate."""

from __future__ import annotations

from statistics import NormalDist

import numpy as np

__all__ = [
    'gaussian_cloud',
    'kld_sample_size',
    'kld_resample',
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


def systematic_resample(weights: np.ndarray, rng: np.random.Generator, count: int | None = None) -> np.ndarray:
    """Indices of the particles kept by systematic resampling (one uniform draw).

    Args:
        weights: ``(P,)`` normalised weights.
        rng: Seeded generator.
        count: How many to draw (P when None).

    Returns:
        ``(count,) int64`` indices into the particle set, sorted.
    """
    count = weights.shape[0] if count is None else count
    positions = (rng.random() + np.arange(count)) / count
    cumulative = np.cumsum(weights)
    cumulative[-1] = 1.0  # guard against round-off leaving the last position unmatched
    return np.searchsorted(cumulative, positions, side='left').astype(np.int64)


def kld_sample_size(occupied_bins: np.ndarray | int, error_bound: float, confidence: float) -> np.ndarray:
    """Fox's bound (KLD-sampling, IJRR 2003): how many samples keep the Kullback-Leibler
    divergence between the sample-based and the true posterior below ``error_bound`` ε with
    probability ``confidence`` 1-δ, when they fall in ``occupied_bins`` k bins of the state space:
    n = (k-1)/(2ε) (1 - 2/(9(k-1)) + sqrt(2/(9(k-1))) z_{1-δ})³ (the Wilson-Hilferty
    approximation of the χ² quantile); 1 for k = 1. Element-wise on an array of k."""
    k = np.maximum(np.asarray(occupied_bins, dtype=np.float64) - 1.0, 0.0)
    quantile = NormalDist().inv_cdf(confidence)
    spread = 2.0 / (9.0 * np.maximum(k, 1.0))
    needed = k / (2.0 * error_bound) * (1.0 - spread + np.sqrt(spread) * quantile) ** 3
    return np.maximum(np.ceil(needed), 1.0)


def kld_resample(
    particles: np.ndarray,
    weights: np.ndarray,
    bin_size: np.ndarray,
    bounds: tuple[int, int],
    error_bound: float,
    confidence: float,
    rng: np.random.Generator,
) -> np.ndarray:
    """Indices of the particles kept by KLD-sampling: as many as the posterior's spread needs.

    Fox's sequential rule, vectorised: ``bounds[1]`` states are drawn from the posterior
    (systematic resampling, in random order); after the i-th draw, k(i) grid cells of
    ``bin_size`` are occupied, and the count is the first i of at least ``bounds[0]`` with
    i >= n(k(i)) (:func:`kld_sample_size`), or ``bounds[1]``. That many are then drawn
    by systematic resampling. The bins are those of the posterior's samples, before the next
    prediction spreads them (Fox bins the predicted ones).

    Args:
        particles: ``(P, D)`` states.
        weights: ``(P,)`` normalised weights.
        bin_size: ``(D,)`` the grid's cell, in the states' units.
        bounds: Least and most particles kept.
        error_bound: ε of :func:`kld_sample_size`.
        confidence: 1-δ of :func:`kld_sample_size`.
        rng: Seeded generator.

    Returns:
        ``(n,) int64`` indices into the particle set, sorted, ``bounds[0] <= n <= bounds[1]``.
    """
    least, most = bounds
    draws = rng.permutation(systematic_resample(weights, rng, most))
    cells = np.floor(particles[draws] / bin_size).astype(np.int64)
    _, first = np.unique(cells, axis=0, return_index=True)
    occupied = np.zeros(most, dtype=np.int64)
    occupied[first] = 1
    drawn = np.arange(1, most + 1)
    enough = (drawn >= least) & (drawn >= kld_sample_size(np.cumsum(occupied), error_bound, confidence))
    count = int(np.argmax(enough)) + 1 if enough.any() else most
    return systematic_resample(weights, rng, count)


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
