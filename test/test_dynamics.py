"""AR(2) dynamics of §2.2 with hand-computed values."""

from __future__ import annotations

import numpy as np
import pytest

from human_tracker.vision.filter.dynamics import ar2_matrix, predict


def test_ar2_matrix_hand_computed() -> None:
    a = ar2_matrix(0.5)
    assert a.shape == (8, 8)
    np.testing.assert_allclose(a[:4, :4], 1.5 * np.eye(4))
    np.testing.assert_allclose(a[:4, 4:], -0.5 * np.eye(4))
    np.testing.assert_allclose(a[4:, :4], np.eye(4))
    np.testing.assert_allclose(a[4:, 4:], 0.0)
    with pytest.raises(ValueError):
        ar2_matrix(1.5)


def test_predict_without_noise_is_a_times_the_last_step() -> None:
    current = np.array([[10.0, 20.0, 30.0, 0.1]])
    previous = np.array([[8.0, 21.0, 30.0, 0.1]])
    new, old = predict(current, previous, 0.5, np.zeros(4), np.random.default_rng(0))
    # x_k = x_{k-1} + 0.5 (x_{k-1} - x_{k-2}): 10 + 0.5 * 2 = 11, 20 + 0.5 * (-1) = 19.5.
    np.testing.assert_allclose(new, [[11.0, 19.5, 30.0, 0.1]])
    np.testing.assert_allclose(old, current)
    # The same as the matrix form X_k = A X_{k-1}.
    stacked = ar2_matrix(0.5) @ np.concatenate([current[0], previous[0]])
    np.testing.assert_allclose(new[0], stacked[:4])


def test_predict_noise_statistics_and_scale_relative_noise() -> None:
    count = 20000
    current = np.tile([0.0, 0.0, 100.0, 0.0], (count, 1))
    new, _ = predict(current, current.copy(), 0.6, np.array([2.0, 3.0, 0.05, 0.1]), np.random.default_rng(1))
    np.testing.assert_allclose(new.std(axis=0), [2.0, 3.0, 5.0, 0.1], rtol=0.03)
    assert new[:, 2].min() > 0
