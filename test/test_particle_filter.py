"""Resampling, the sample size and the state estimate, hand-computed."""

from __future__ import annotations

import numpy as np
import pytest

from human_tracker.vision.filter.particle_filter import (
    effective_sample_size,
    gaussian_cloud,
    kld_resample,
    kld_sample_size,
    systematic_resample,
    weighted_covariance,
    weighted_estimate,
)


def test_systematic_resample_keeps_particles_in_proportion() -> None:
    weights = np.array([0.5, 0.25, 0.25, 0.0])
    keep = systematic_resample(weights, np.random.default_rng(0))
    assert np.bincount(keep, minlength=4).tolist() == [2, 1, 1, 0]


def test_kld_sample_size_is_the_chi_square_quantile_over_twice_the_error() -> None:
    # n = χ²(k-1, 1-δ) / 2ε (Fox 2003); χ² quantiles at 0.99: 1 dof 6.635, 9 dof 21.666, 99 dof 134.642.
    # The Wilson-Hilferty approximation is within 1 % from 9 degrees of freedom, 0.5 % at 1.
    needed = kld_sample_size(np.array([2, 10, 100]), 0.05, 0.99)
    np.testing.assert_allclose(needed, np.ceil(np.array([6.635, 21.666, 134.642]) / 0.1), rtol=0.01, atol=1)
    assert kld_sample_size(1, 0.05, 0.99) == 1
    assert kld_sample_size(10, 0.025, 0.99) > kld_sample_size(10, 0.05, 0.99) > kld_sample_size(10, 0.05, 0.9)


def test_kld_resample_keeps_as_many_as_the_spread_needs_within_bounds() -> None:
    rng = np.random.default_rng(0)
    bins = np.array([1.0, 1.0, 1.0, 0.1])
    weights = np.full(1000, 1e-3)
    tight = np.tile([10.5, 10.5, 20.5, 0.05], (1000, 1))  # one bin
    spread = gaussian_cloud(np.array([50.0, 50.0, 20.0, 0.0]), np.array([5.0, 5.0, 0.1, 0.1]), 1000, rng)
    assert len(kld_resample(tight, weights, bins, (50, 1000), 0.05, 0.99, rng)) == 50
    many = kld_resample(spread, weights, bins, (50, 1000), 0.05, 0.99, rng)
    assert len(many) == 1000  # hundreds of bins: the bound exceeds the most
    some = kld_resample(spread, weights, bins * 10, (50, 1000), 0.05, 0.99, rng)
    assert 50 < len(some) < 1000
    # Half the weight on one particle: the kept ones follow the weights.
    weights = np.full(1000, 0.5 / 999)
    weights[0] = 0.5
    kept = kld_resample(spread, weights, bins * 10, (50, 1000), 0.05, 0.99, rng)
    assert np.count_nonzero(kept == 0) == pytest.approx(len(kept) / 2, abs=1)


def test_effective_sample_size() -> None:
    assert effective_sample_size(np.full(8, 1 / 8)) == pytest.approx(8)
    assert effective_sample_size(np.array([1.0, 0.0, 0.0])) == pytest.approx(1)
    assert effective_sample_size(np.array([0.5, 0.5, 0.0])) == pytest.approx(2)


def test_weighted_estimate_averages_theta_on_the_circle() -> None:
    particles = np.array([[0.0, 0.0, 10.0, np.pi - 0.1], [10.0, 4.0, 20.0, -np.pi + 0.1]])
    estimate = weighted_estimate(particles, np.array([0.5, 0.5]))
    np.testing.assert_allclose(estimate[:3], [5.0, 2.0, 15.0])
    assert abs(abs(estimate[3]) - np.pi) < 1e-9


def test_weighted_covariance_hand_computed() -> None:
    samples = np.array([[0.0, 0.0], [2.0, 4.0]])
    np.testing.assert_allclose(weighted_covariance(samples, np.array([0.5, 0.5])), [[1.0, 2.0], [2.0, 4.0]])


def test_gaussian_cloud_spreads_scale_relatively() -> None:
    cloud = gaussian_cloud(
        np.array([100.0, 50.0, 80.0, 0.0]), np.array([4.0, 2.0, 0.1, 0.05]), 20000, np.random.default_rng(3)
    )
    np.testing.assert_allclose(cloud.mean(axis=0), [100.0, 50.0, 80.0, 0.0], atol=0.2)
    np.testing.assert_allclose(cloud.std(axis=0), [4.0, 2.0, 8.0, 0.05], rtol=0.03)
