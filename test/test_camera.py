"""Metric position from scale and intrinsics, hand-computed."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from human_tracker.vision.filter.templates import head_and_shoulders
from human_tracker.vision.geometry.camera import (
    default_camera_matrix,
    metric_positions,
    position_covariance,
    undistort_pixels,
)


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


def test_a_distorted_pixel_becomes_the_ray_of_its_point() -> None:
    """A point seen through a lens with barrel distortion (plumb_bob) is undistorted back to where
    a pinhole camera with the same K sees it, and its metric position is the point's."""
    k = np.array([[500.0, 0, 320.0], [0, 500.0, 240.0], [0, 0, 1]])
    distortion = np.array([-0.3, 0.1, 0.001, -0.002, 0.0])
    point = np.array([[0.2, -0.12, 0.8]])
    seen, _ = cv2.projectPoints(point, np.zeros(3), np.zeros(3), k, distortion)
    ideal, _ = cv2.projectPoints(point, np.zeros(3), np.zeros(3), k, None)
    seen, ideal = seen.reshape(1, 2), ideal.reshape(1, 2)
    # Hand-checked: x = 0.25, y = -0.15, r² = 0.085: the radial factor 1 - 0.3 r² + 0.1 r⁴ = 0.975.
    assert np.linalg.norm(seen - ideal) > 3.0  # pixels: the distortion matters at this radius
    np.testing.assert_allclose(undistort_pixels(seen, k, distortion), ideal, atol=1e-3)
    np.testing.assert_array_equal(undistort_pixels(seen, k, None), seen)
    np.testing.assert_array_equal(undistort_pixels(seen, k, np.zeros(5)), seen)
    template = head_and_shoulders()  # head box centre (0, -0.005) head widths from the state
    width = 500.0 * 0.16 / 0.8  # pixels, for a 0.16 m head at 0.8 m
    state = np.array([seen[0, 0], seen[0, 1] + 0.005 * width, width, 0.0])
    np.testing.assert_allclose(metric_positions(state, template, k, 0.16, distortion), point[0], atol=1e-5)
    assert np.linalg.norm(metric_positions(state, template, k, 0.16) - point[0]) > 0.005


def test_the_pose_covariance_adds_the_contours_own_error() -> None:
    """Hand-computed: a cloud of ±1 cm in x only, a contour 5.5 px off on a head 50 px wide
    (share 0.11), a 0.16 m head at 2 m: σ = 0.0176 m across; along the ray the distance's
    share and the width's spread of 5 %, 2 hypot(0.11, 0.05) = 0.2417 m, which off the axis
    (x = 0.5 m: ray (0.25, 0, 1)) moves x with z. With a depth image's spread of 3 cm, that
    along the ray."""
    cloud = np.array([[-0.01, 0.0, 2.0], [0.01, 0.0, 2.0]])
    covariance = position_covariance(cloud, np.array([0.0, 0.0, 2.0]), 5.5 / 50.0, 0.16)
    along = 2.0 * np.hypot(0.11, 0.05)
    np.testing.assert_allclose(np.diag(covariance), [2e-4 + 0.0176**2, 0.0176**2, along**2])
    assert covariance[0, 1] == 0.0 and covariance[0, 2] == 0.0
    aside = position_covariance(cloud, np.array([0.5, 0.0, 2.0]), 5.5 / 50.0, 0.16)
    np.testing.assert_allclose(aside[0, 0], 2e-4 + 0.0176**2 + (0.25 * along) ** 2)
    np.testing.assert_allclose([aside[0, 2], aside[1, 2]], [0.25 * along**2, 0.0])
    width_only = position_covariance(cloud, cloud[0], 0.0, 0.16)
    np.testing.assert_allclose(width_only - np.cov(cloud.T), (0.1**2) * np.outer([-0.005, 0, 1], [-0.005, 0, 1]))
    measured = position_covariance(cloud, np.array([0.0, 0.0, 2.0]), 0.11, 0.16, depth_spread=0.03)
    assert measured[2, 2] == pytest.approx(0.03**2)
