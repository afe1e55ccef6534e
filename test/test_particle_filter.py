"""Resampling and the state estimate, hand-computed."""

from __future__ import annotations

import numpy as np
import pytest

from human_tracker.vision.particle_filter import (
    effective_sample_size,
    gaussian_cloud,
    systematic_resample,
    weighted_covariance,
    weighted_estimate,
)


def test_systematic_resample_keeps_particles_in_proportion() -> None:
    weights = np.array([0.5, 0.25, 0.25, 0.0])
    keep = systematic_resample(weights, np.random.default_rng(0))
    assert np.bincount(keep, minlength=4).tolist() == [2, 1, 1, 0]


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
