"""Metric position from scale and intrinsics, hand-computed."""

from __future__ import annotations

import numpy as np
import pytest

from human_tracker.vision.camera import default_camera_matrix, metric_positions
from human_tracker.vision.templates import head_and_shoulders


def test_metric_position_hand_computed() -> None:
    template = head_and_shoulders()  # head box (-0.5, -0.63, 1, 1.25): centre (0, -0.005)
    k = np.array([[500.0, 0, 320.0], [0, 500.0, 240.0], [0, 0, 1]])
    position = metric_positions(np.array([420.0, 240.0, 100.0, 0.0]), template, k, 0.16)
    # Z = f W / w = 500 * 0.16 / 100 = 0.8 m; X = (420 - 320) * 0.8 / 500 = 0.16 m;
    # Y = (240 + 100 * -0.005 - 240) * 0.8 / 500 = -0.0008 m.
    np.testing.assert_allclose(position, [0.16, -0.0008, 0.8], atol=1e-12)
    both = metric_positions(np.array([[420.0, 240.0, 100.0, 0.0], [320.0, 240.25, 50.0, 0.0]]), template, k, 0.16)
    # Head centre at v = 240.25 + 50 * -0.005 = 240: on the optical axis, at 500 * 0.16 / 50 = 1.6 m.
    np.testing.assert_allclose(both[1], [0.0, 0.0, 1.6], atol=1e-12)


def test_default_camera_has_a_60_degree_field_of_view() -> None:
    k = default_camera_matrix(640, 480)
    assert 2 * np.degrees(np.arctan(320 / k[0, 0])) == pytest.approx(60.0)
    assert (k[0, 2], k[1, 2]) == (319.5, 239.5)
