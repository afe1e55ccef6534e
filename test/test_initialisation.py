"""Initialisation from the moving region (§2.5), hand-computed."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from human_tracker.vision.filter.templates import head_and_shoulders
from human_tracker.vision.track.initialisation import (
    first_local_maximum,
    largest_blob,
    moments_state,
    state_from_moments,
    state_from_scan,
    upper_end_state,
)

TEMPLATE = head_and_shoulders()  # head box (-0.5, -0.63, 1, 1.25): one unit wide


def test_first_local_maximum() -> None:
    assert first_local_maximum(np.array([1, 2, 3, 2, 5])) == 2
    assert first_local_maximum(np.array([1, 2, 2, 1])) == 1  # a plateau counts at its start
    assert first_local_maximum(np.array([1, 2, 3])) is None


def test_largest_blob() -> None:
    mask = np.zeros((20, 20), np.uint8)
    mask[1:3, 1:3] = 255
    mask[10:15, 10:15] = 255
    blob = largest_blob(mask)
    assert blob.sum() == 25 and blob[12, 12]
    assert largest_blob(mask, min_area=30) is None
    assert largest_blob(np.zeros((5, 5), np.uint8)) is None


def test_moments_of_a_rotated_ellipse() -> None:
    # Semi-axes 20 (across) and 40 (along), turned by θ = 0.3 rad: a uniform ellipse has
    # variance a²/4 across, so 4 sqrt(λ_minor) = 40 px = the width: s = 40 / 1.
    mask = np.zeros((240, 320), np.uint8)
    cv2.ellipse(mask, (160, 120), (20, 40), np.degrees(0.3), 0, 360, 255, -1)
    x, y, s, theta = state_from_moments(mask, TEMPLATE)
    assert theta == pytest.approx(0.3, abs=0.02)
    assert s == pytest.approx(40.0, rel=0.03)
    # The head box centre (template (0, -0.005)) sits on the blob's centroid.
    centre = np.array([x, y]) + s * np.array([0.005 * np.sin(theta), -0.005 * np.cos(theta)])
    np.testing.assert_allclose(centre, [160, 120], atol=0.6)
    assert state_from_moments(np.zeros((10, 10), np.uint8), TEMPLATE) is None


def test_upper_end_of_a_forearm_and_hand() -> None:
    # A vertical bar 20 px wide and 100 tall (a raised forearm and hand): across it the
    # columns' variance is (20² - 1) / 12 = 33.25, 4 sqrt(33.25) = 23.07 px, so its upper end
    # is the top 1.3 * 23.07 = 29.98 px: rows 40-69, where the whole bar's moments put X_0
    # on row 90.
    blob = np.zeros((240, 320), bool)
    blob[40:140, 150:170] = True
    end = upper_end_state(blob, TEMPLATE)
    whole = moments_state(blob, TEMPLATE)
    top = np.zeros_like(blob)
    top[40:70, 150:170] = True
    np.testing.assert_allclose(end, moments_state(top, TEMPLATE), atol=1e-6)
    assert end[1] < whole[1] - 30
    # Not twice as long as wide: no upper end, the moments are X_0.
    square = np.zeros((240, 320), bool)
    square[40:75, 150:170] = True
    assert upper_end_state(square, TEMPLATE) is None


def test_scan_finds_the_head_top_and_width() -> None:
    # A head disc of radius 20 at (100, 60), a neck 16 px wide, shoulders 120 px wide below.
    mask = np.zeros((200, 200), np.uint8)
    cv2.circle(mask, (100, 60), 20, 255, -1)
    mask[78:92, 92:108] = 255
    mask[92:, 40:160] = 255
    x, y, s, theta = state_from_scan(mask, TEMPLATE, upright_angle=0.0)
    # Top row 40; first width maximum ≈ the head's 41 px diameter (smoothed over 5 rows);
    # the head box top (template y = -0.63) hangs from row 40: y = 40 + 0.63 s.
    assert s == pytest.approx(41, abs=2)
    assert x == pytest.approx(100, abs=1)
    assert y == pytest.approx(40 + 0.63 * s, abs=1)
    assert theta == 0.0
    assert state_from_scan(np.zeros((50, 50), np.uint8), TEMPLATE) is None
